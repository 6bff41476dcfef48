// CUDA backend of the quasistatic simulator: a device mirror of a built
// seamfit::sim::Simulator (topology, rest state, body SDF) and the
// Chebyshev-accelerated block-Jacobi solve on the GPU with the CPU solver's
// rules. State stays on the device across iterations; the host looks in once
// per batch of iterations (a CUDA graph). Host-only interface: no CUDA types.
#pragma once
#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>

#include "device/cuda_error.hpp"
#include "sim/simulator.hpp"

namespace seamfit::cuda {

struct GpuOptions {
  int device = 0;
  int block = 128;           // threads per block of the per-vertex kernels (32, 64, 128 or 256)
  int lanes = 0;             // threads per vertex in the evaluation (1, 2, 4 or 8; 0: 2 if that fits one wave, else 1)
  int batch = 32;            // iterations per graph launch between host looks (even)
  bool use_graph = true;     // false: plain launches (for measuring launch overhead)
  bool float_rest = false;   // store rest lengths, shirring, Q, masses and barrier weights as float32
};

// Per-kernel device times (microseconds) and their byte counts.
struct KernelTimes {
  double eval_us = 0, step_us = 0, slot_us = 0;  // eval: with the control step; slot: step + eval + control
  double eval_bytes = 0, step_bytes = 0;                       // unique bytes each kernel must move
};

// Device pointers of the pattern, its float64 rest state and the topology that
// goes with them, for the CUDA code beside the simulator (df/dp,
// dfdp_gpu.cu): valid after sync() until the next one.
struct DeviceRest {
  int n = 0, n_springs = 0, n_tris = 0, n_hinges = 0;
  const double *p = nullptr, *rest_L = nullptr, *shirring = nullptr, *mass = nullptr;
  const uint8_t* L_floored = nullptr;
  const int32_t *spring_v = nullptr, *vs_ptr = nullptr, *vs_idx = nullptr;
  const int32_t *tris = nullptr, *vt_ptr = nullptr, *vt_idx = nullptr;
  const int32_t *hinge_v = nullptr, *vh_ptr = nullptr, *vh_idx = nullptr;
};

// Copies `bytes` from device memory to host memory (synchronously).
void copy_to_host(void* dst, const void* src, size_t bytes);

class SimGpu {
 public:
  // Copies the simulator's topology, rest state, parameters and body. `sim`
  // must outlive this object (sync() reads it again).
  SimGpu(const sim::Simulator& sim, const GpuOptions& opt = GpuOptions());
  ~SimGpu();
  SimGpu(const SimGpu&) = delete;
  SimGpu& operator=(const SimGpu&) = delete;

  // Bring the device up to the simulator's model: call after set_params /
  // set_pattern / set_shirring / set_sticking / set_sdf on it. Only what changed
  // moves: a new pattern p (2n doubles) is uploaded and its rest state (rest
  // lengths, masses, barrier weights, Q, the residual scale) recomputed here on
  // the device (sim/rest_state.hpp), so the CPU simulator never has to.
  void sync();
  double weight_norm() const;  // |m g0| of the synced rest state (the residual scale)
  // As Simulator::first_inside (the least index of a vertex with phi <= 0 in the
  // barrier's field, or -1), sampled on the device: the CPU's serial scan costs
  // milliseconds at 60K triangles, and every GPU entry point checks its x.
  int first_inside(const double* x, double* phi_out = nullptr);
  // For x (3n) in device memory: the least index of a vertex with a coordinate that
  // is not finite or, with the barrier, phi not above `floor`; -1 if none.
  int first_unsafe_device(const double* d_x, double floor);
  DeviceRest device_rest() const;

  // f = -dE/dx (3n) at x; returns the energy (+inf with a vertex inside).
  double force(const double* x, double* f, sim::EnergyTerms* terms);
  double energy(const double* x, sim::EnergyTerms* terms);
  // out = (d2E/dx2) v (3n) at x, exact or PSD-projected, as Simulator::hess_vec.
  void hess_vec(const double* x, const double* v, double* out, bool psd);
  // The Chebyshev solve of Simulator::solve (method 0) on the device.
  sim::SolveReport solve(double* x, const sim::SolveSettings& s, const sim::ProgressFn& progress,
                         const std::atomic<bool>* cancel = nullptr);
  // The same solve with x (3n) in device memory, in and out: the search's inexact
  // steps, whose state stays on the device. A start with a vertex to project (or a
  // coordinate not finite) takes the host path, so the rules are the CPU's.
  sim::SolveReport solve_device(double* d_x, const sim::SolveSettings& s, const sim::ProgressFn& progress,
                                const std::atomic<bool>* cancel = nullptr);
  // A new pattern p (2n doubles in device memory) and its rest state, computed here,
  // without the CPU simulator: until its next set_pattern (which sync() then
  // uploads), the device's pattern is ahead of the CPU's.
  void set_pattern_device(const double* d_p);

  // Device times of the iteration's kernels at x, median of `reps` graph replays.
  KernelTimes time_kernels(const double* x, int reps);

  const GpuOptions& options() const { return opt_; }
  const sim::Simulator& simulator() const;
  int lanes() const;  // threads per vertex in the evaluation, as chosen
  std::string device_name() const;
  size_t device_bytes() const;

  // For the CUDA code beside the simulator (the adjoint, adjoint_gpu.cu),
  // opaque so that this header stays free of CUDA types: the model on the
  // device (a DevModel<float> when options().float_rest, else DevModel<double>)
  // and the stream (a cudaStream_t) its kernels run on.
  const void* device_model() const;
  void* stream_handle() const;

  struct Impl;

 private:
  void update_rest_state();  // from the uploaded p, on the device
  void refresh_model();      // the device model's pointers and parameters; marks the graph stale if they moved
  sim::SolveReport run_chebyshev(const sim::SolveSettings& s, const sim::ProgressFn& progress,
                                 const std::atomic<bool>* cancel, std::chrono::steady_clock::time_point t0,
                                 sim::SolveReport rep, int& cur);  // from seeded state buffers
  GpuOptions opt_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace seamfit::cuda
