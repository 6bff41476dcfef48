// Quasistatic garment simulator Sim_phi(theta) (Wang 2018, section 4), CPU.
//
// x = argmin  E_stretch + E_sewing + E_bend + G + F_stick - sum_i c_i log phi(x_i)
//
// Layout (shared with a future CUDA port): structure-of-arrays element lists
// (springs, sewing pairs, hinges, triangles) plus per-vertex incidence lists
// (CSR) so every per-vertex quantity is a gather, never an atomic scatter. The
// per-vertex neighbour list (CSR, sorted, self included) is also the block
// sparsity pattern of the 3N x 3N Hessian; the constant bending matrix Q lives
// on it, and Hessian assembly writes each vertex's three columns in place.
//
// Units: SI. x and p in metres, forces in N, energies in J.
// Not thread-safe: one Simulator per thread (it owns scratch buffers).
#pragma once
#include <Eigen/Sparse>
#include <atomic>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "body/sdf_grid.hpp"
#include "common/vec3.hpp"
#include "sim/math.hpp"

namespace seamfit::sim {

// Invalid input or a state the model cannot evaluate (reported to Python as
// seamfit.errors.SolveError).
struct SimError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SimParams {
  double stretch_Y = 0;     // Y^patch (N): spring force scale, E = Y/(2L)(l - rL)^2
  double sewing_Y = 0;      // Y^sewing (N/m)
  double bend_kb = 0;       // flexural rigidity (N m)
  double density = 0;       // areal density rho (kg/m^2)
  Vec3 gravity{0, 0, -9.81};  // m/s^2
  double mu = 0.01;         // dimensionless barrier strength
  double barrier_length = 0.1;  // l_b (m): c_i = mu * l_b * g0 * m_i
  double barrier_distance = 0.01;  // activation distance d (m): no barrier for phi >= d
  // Barrier field: C2 cubic B-spline of the grid values (true) or the grid's
  // trilinear interpolant (false); see sim/terms/sdf_smooth.hpp for why.
  bool barrier_smooth = true;
};

// Standard gravity used to scale the barrier weight (kept when gravity is
// switched off during dressing, so the body stays a barrier).
constexpr double kG0 = 9.81;

struct EnergyTerms {
  double stretch = 0, sewing = 0, bending = 0, gravity = 0, sticking = 0, barrier = 0;
  double total() const { return stretch + sewing + bending + gravity + sticking + barrier; }
};

struct SolveSettings {
  int method = 0;            // 0: Chebyshev-accelerated Jacobi gradient descent, 1: Newton
  int max_iterations = 20000;
  double tolerance = 1e-2;   // on the relative residual |f| / |m g|
  double max_seconds = 0;    // 0: no limit
  double rho = 0;            // Chebyshev spectral radius; <= 0: estimate and adapt
  double rho_max = 0.9999995;  // the adapted rho's upper bound (docs/simulator.md)
  double alpha = 0.9;        // Jacobi step length
  int warmup = 16;           // plain Jacobi iterations after each (re)start
  int check_every = 8;       // energy check / checkpoint interval (Chebyshev)
  int progress_every = 50;   // callback interval (iterations)
  int history_every = 10;    // residual history interval (iterations)
  bool newton_exact_first = true;  // Newton: try the exact Hessian before the PSD one
  // Newton: block-Jacobi sweeps after each Newton step (0: pure Newton).
  int newton_smoothing = 0;
  // Economies of the Chebyshev loop, CPU and GPU alike (the rules are shared,
  // sim/jacobi_step.hpp): the springs' share of the Jacobi blocks is refreshed
  // every precond_refresh iterations (it changes slowly, and costs a third of an
  // evaluation; only while the energy keeps falling), and a step that provably
  // ends beyond the barrier's reach is bounded instead of sampled (far_bound).
  // They change the drape, not only its cost: with 1 and false the GarmentCode
  // pants (3 cm mesh) settle 4.2 cm lower than with 4 and true (2.06 against 1.21 J).
  int precond_refresh = 4;
  bool far_bound = true;
};

struct SolveReport {
  int iterations = 0;
  double seconds = 0;
  double residual = 0;       // relative residual at the returned x
  double energy = 0;
  bool converged = false;
  bool cancelled = false;
  int restarts = 0;          // Chebyshev restarts after an energy rise
  int projections = 0;       // vertices projected out of the body
  long rejected_steps = 0;   // vertex steps dropped by the barrier-safe step
  double final_rho = 0, final_alpha = 0;
  long linear_iterations = 0;  // Newton with an outside step solver: its iterations, all steps
  std::string message;
  std::vector<double> hist_iter, hist_seconds, hist_residual;

  // One row of the residual history: iteration, seconds since the start, residual.
  void record(double iteration, double at_seconds, double res) {
    hist_iter.push_back(iteration);
    hist_seconds.push_back(at_seconds);
    hist_residual.push_back(res);
  }
};

// Progress callback: (iteration, residual) -> keep going?
using ProgressFn = std::function<bool(int, double)>;

// An outside solver of the Newton system, in place of the sparse LDL^T (the
// GPU's MINRES, seamfit::cuda::newton_on_gpu): fills dx (3n) with an
// approximate solution of (H(x) + shift_rel * mean|diag H|) dx = f, H exact or
// PSD-projected (psd), to a relative residual of `forcing`. Returns the
// iterations it took, or -1 when it failed.
using NewtonStepFn = std::function<int(const double* x, bool psd, double shift_rel, const double* f, double forcing,
                                       double* dx)>;

// Read-only view of the assembled topology, rest state and body of a
// Simulator, for backends that mirror it elsewhere (the CUDA backend copies
// these to the device). Pointers are into the Simulator and stay valid until
// it changes; CSR lengths are ptr[n].
struct SimArrays {
  int n = 0, n_springs = 0;
  const int32_t* spring_v = nullptr;                            // 2E
  const int32_t *vs_ptr = nullptr, *vs_idx = nullptr;           // springs at a vertex: e*2 + side
  const int32_t *vw_ptr = nullptr, *vw_idx = nullptr;           // sewing partners
  const int32_t *nbr_ptr = nullptr, *nbr_idx = nullptr, *self_slot = nullptr;  // block pattern
  const double *rest_L = nullptr, *shirring = nullptr;          // E
  const double* Q = nullptr;                                    // on the block pattern
  const double *mass = nullptr, *barrier_c = nullptr;           // n
  const double *stick_k = nullptr, *stick_t = nullptr;          // n, 3n
  bool any_sticking = false;
  // For (df/dp)^T lam: the pattern, the triangles and hinges with their
  // incidence, springs whose rest length is floored (no p-derivative) and the
  // mass floor below which a vertex's barrier weight does not follow its mass.
  const double* p = nullptr;                                    // 2n
  int n_tris = 0, n_hinges = 0;
  const int32_t *tris = nullptr, *vt_ptr = nullptr, *vt_idx = nullptr;     // 3T; triangles at a vertex: t*3 + k
  const int32_t *hinge_v = nullptr, *vh_ptr = nullptr, *vh_idx = nullptr;  // 4H; hinges at a vertex: h*4 + k
  const uint8_t* L_floored = nullptr;                           // E
  double m_floor = 0;
  double L_floor = 0;         // rest lengths below it are floored there
  // The rest state (rest_L, Q, mass, barrier_c) is recomputed from p on first
  // use after set_pattern: while rest_stale, those arrays are out of date (the
  // GPU recomputes them from p itself). rest_revision changes whenever p or
  // the mass or barrier parameters do.
  bool rest_stale = false;
  uint64_t rest_revision = 0;
  uint64_t shirring_revision = 0, sticking_revision = 0;  // change with set_shirring / set_sticking
  bool has_sdf = false;
  SdfGridView sdf;            // host memory
  uint64_t sdf_revision = 0;  // changes whenever set_sdf / clear_sdf runs
};

class Simulator {
 public:
  // p: 2n pattern coordinates (m); tris: 3T vertex indices; sew: 2K vertex pairs.
  Simulator(int n, const double* p, int n_tris, const int32_t* tris, int n_sew, const int32_t* sew,
            const SimParams& params);

  // --- configuration -------------------------------------------------------
  void set_sdf(const float* values, int nx, int ny, int nz, const double origin[3], double spacing);
  // As set_sdf, without a copy: the caller keeps `values` alive and unchanged
  // while the simulator uses it (a body's field is shared by its simulators).
  void set_sdf_view(const float* values, int nx, int ny, int nz, const double origin[3], double spacing);
  void clear_sdf();
  bool has_sdf() const { return has_sdf_; }
  // The barrier term is on: a body, and a positive strength mu.
  bool barrier_on() const { return has_sdf_ && params_.mu > 0; }
  void set_params(const SimParams& params);  // everything but the topology
  const SimParams& params() const { return params_; }
  SimArrays arrays() const;
  void set_pattern(const double* p);         // new rest state (2n), computed on first use
  void set_shirring(const double* r);        // per patch spring (n_springs)
  // Sticking: k (N/m) per vertex (0 = free) and target positions (3n).
  void set_sticking(const double* k, const double* targets);

  // --- sizes and layout ----------------------------------------------------
  int n_vertices() const { return n_; }
  int n_triangles() const { return int(tris_.size() / 3); }
  int n_springs() const { return int(spring_v_.size() / 2); }
  int n_sewing() const { return int(sew_v_.size() / 2); }
  int n_hinges() const { return int(hinge_v_.size() / 4); }
  const std::vector<int32_t>& springs() const { return spring_v_; }
  const std::vector<int32_t>& sewing() const { return sew_v_; }
  const std::vector<int32_t>& hinges() const { return hinge_v_; }
  const std::vector<double>& masses() const { ensure_rest_state(); return mass_; }
  const std::vector<double>& rest_lengths() const { ensure_rest_state(); return rest_L_; }
  double weight_norm() const { ensure_rest_state(); return weight_norm_; }  // |m g0| (N), residual scale

  // --- evaluation (x: 3n) --------------------------------------------------
  // Index of the first vertex with phi <= 0 (the barrier is undefined there), or -1.
  int first_inside(const double* x, double* phi_out = nullptr) const;
  // Signed distance at every vertex (n); +inf everywhere when no SDF is set.
  // barrier_field: the field the barrier sees (see SimParams::barrier_smooth);
  // otherwise the grid's trilinear interpolant (sdf_sample).
  void sample_phi(const double* x, double* phi, bool barrier_field = false) const;
  // Energy (+inf if a vertex is inside the body).
  double energy(const double* x, EnergyTerms* terms = nullptr);
  // f = -dE/dx (3n); returns the energy. Precondition: no vertex inside.
  double force(const double* x, double* f, EnergyTerms* terms = nullptr);
  // Relative residual |f| / |m g0|.
  double residual(const double* f) const;
  // Hessian d2E/dx2 (exact) or its PSD-projected variant, 3n x 3n, column
  // major, symmetric (both triangles stored). The reference is to a buffer
  // owned by the simulator and overwritten by the next hessian() or Newton solve.
  const Eigen::SparseMatrix<double>& hessian(const double* x, bool psd);
  // (d2E/dx2) v, matrix-free.
  void hess_vec(const double* x, const double* v, double* out, bool psd);
  // (df/dp)^T lambda (2n), f = -dE/dx, matrix-free.
  void dfdp_T(const double* x, const double* lam, double* out);
  // Per-vertex sewing gaps |x_i - x_j| (n_sewing).
  void sewing_gaps(const double* x, double* gaps) const;

  // --- projection and solvers ----------------------------------------------
  // Moves vertices with phi < floor outside, to phi = target. Returns the count.
  int project_outside(double* x, double floor, double target) const;
  double projection_gap() const;  // barrier rest gap mu * l_b (bounded)
  // OpenMP threads for this simulator: 0 = automatic (one thread for small
  // meshes, where fork/join costs more than the work; all threads otherwise).
  void set_threads(int threads);
  int threads() const { return threads_; }
  // `step`, for the Newton method only: solves its linear systems (default:
  // sparse LDL^T on this CPU).
  SolveReport solve(double* x, const SolveSettings& s, const ProgressFn& progress,
                    const std::atomic<bool>* cancel = nullptr, const NewtonStepFn& step = {});

 private:
  void build_topology(int n_tris, const int32_t* tris, int n_sew, const int32_t* sew);
  void build_hessian_pattern();
  int slot_of(int v, int u) const;
  void update_rest_state();
  void ensure_rest_state() const;  // update_rest_state + barrier weights when p changed since
  void update_barrier_weights();
  // Fused pass: energy terms, force, and (optionally) PSD diagonal blocks.
  // samples: per-vertex SDF samples, written here, or read when samples_known
  // (the caller sampled x already). reuse_spring_diag: the springs' share of
  // the diagonal blocks is taken from the last call (a preconditioner may lag).
  void evaluate(const double* x, double* f, EnergyTerms* terms, Sym3* diag, SdfSample* samples,
                bool samples_known = false, bool reuse_spring_diag = false);
  SolveReport solve_chebyshev(double* x, const SolveSettings& s, const ProgressFn& progress,
                              const std::atomic<bool>* cancel);
  SolveReport solve_newton(double* x, const SolveSettings& s, const ProgressFn& progress,
                           const std::atomic<bool>* cancel, const NewtonStepFn& step);
  // Plain block-Jacobi descent sweeps (barrier-safe, energy never rises);
  // returns the energy at the result.
  double jacobi_sweeps(double* x, int sweeps, double alpha);
  SdfSample sdf_at(Vec3 p) const;   // the barrier's field: value and gradient
  Sym3 sdf_hess_at(Vec3 p) const;    // and its Hessian

  int n_;
  int threads_ = 1;
  SimParams params_;
  std::vector<double> p_;          // 2n
  std::vector<int32_t> tris_;      // 3T
  std::vector<int32_t> spring_v_;  // 2E
  std::vector<int32_t> sew_v_;     // 2K
  std::vector<int32_t> hinge_v_;   // 4H
  // Per-vertex incidence (CSR).
  std::vector<int32_t> vs_ptr_, vs_idx_, vs_slot_;   // springs: e*2+side, slot of the other end
  std::vector<int32_t> vw_ptr_, vw_idx_, vw_slot_;   // sewing: partner vertex, its slot
  std::vector<int32_t> vh_ptr_, vh_idx_;             // hinges: h*4+k
  std::vector<int32_t> vt_ptr_, vt_idx_;             // triangles: t*3+k
  std::vector<int32_t> nbr_ptr_, nbr_idx_, self_slot_;  // block pattern
  // Rest state (depends on p).
  std::vector<double> rest_L_, shirring_, hinge_K_, hinge_w_, Q_, mass_, tri_area_, barrier_c_;
  std::vector<uint8_t> L_floored_;  // rest length clamped at L_floor_ (no p-derivative)
  double L_floor_ = 0, m_floor_ = 0;
  double weight_norm_ = 0;
  mutable bool rest_stale_ = false;
  uint64_t rest_revision_ = 0, shirring_revision_ = 0, sticking_revision_ = 0;
  // Sticking.
  std::vector<double> stick_k_, stick_t_;
  bool any_sticking_ = false;
  // Body.
  bool has_sdf_ = false;
  uint64_t sdf_revision_ = 0;
  std::vector<float> sdf_values_;
  SdfGridView sdf_;
  // Scratch.
  std::vector<Vec3> spring_g_;
  std::vector<Sym3> spring_H_;
  std::vector<double> scratch_;
  Eigen::SparseMatrix<double> H_;
};

}  // namespace seamfit::sim
