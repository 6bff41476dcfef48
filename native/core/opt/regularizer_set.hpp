// Boundary regularizers R^fix (Eq. 9) and R^cur (Eq. 10) over theta, and the
// preconditioner of Section 7.
//
// Both regularizers are quadratic in theta (see opt/costs/regularizers.hpp for how
// T_i is defined), so the Hessian of R = R^fix + R^cur is the constant matrix
//   P = delta_fix I + delta_cur sum_i w_i A_i^T A_i,
// with A_i the 2 x 6 map from (p_j, p_i, p_k) to the curve residual. The paper holds
// T_i constant to get a constant approximate Hessian; with our chord-frame T_i this
// constant matrix is the exact Hessian of R. delta_fix > 0 makes P positive definite
// (R^cur alone is blind to every similarity motion of a panel).
#pragma once
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <array>
#include <vector>

#include "opt/topology.hpp"
#include "opt/vec2.hpp"

namespace seamfit::opt {

class Regularizers {
 public:
  // theta_bar: (n_theta, 2) base boundary positions. loops: closed outlines as indices
  // into theta, in outline order (either direction). weight: per theta entry w_i of
  // R^cur (smaller at corners).
  Regularizers(const std::vector<Vec2>& theta_bar, const std::vector<std::vector<int>>& loops,
               const std::vector<double>& weight);

  void set_strengths(double delta_fix, double delta_cur);
  double delta_fix() const { return fix_; }
  double delta_cur() const { return cur_; }

  // Value (R^fix + R^cur); terms = {R^fix, R^cur}; gradient (n_theta, 2) overwritten.
  double evaluate(const Vec2* theta, Vec2* grad, std::array<double, 2>* terms) const;

  // P^-1 g. The factorization is rebuilt when the strengths change.
  void apply_preconditioner(const Vec2* g, Vec2* out);
  // P^-1 as a dense symmetric (2 n_theta)^2 matrix, row-major, from the factorization
  // (one solve per column, in parallel, then symmetrized): the GPU's preconditioner.
  void dense_inverse(double* out);
  // Changes whenever P does (strengths, extra block): a copy of P or P^-1 elsewhere is
  // current while its version matches.
  long preconditioner_version() const { return version_; }
  Eigen::SparseMatrix<double> hessian() const;
  // A constant matrix added to P (the seam term's Gauss-Newton Hessian at the base
  // pattern, seamfit.opt.seam); an empty matrix removes it.
  void set_extra_hessian(const Eigen::SparseMatrix<double>& H);

  int n_theta() const { return int(theta_bar_.size()); }
  // Curve elements (j, i, k) and their frames z_i and weights w_i.
  const std::vector<std::array<int, 3>>& curve_elements() const { return elem_; }
  const std::vector<Vec2>& curve_frames() const { return z_; }
  const std::vector<double>& curve_weights() const { return w_; }
  const std::vector<Vec2>& theta_bar() const { return theta_bar_; }
  // theta entry -> its curve element slots (3 e + a).
  const Gather& curve_gather() const { return gather_; }

 private:
  void factorize();
  std::vector<Vec2> theta_bar_;
  std::vector<std::array<int, 3>> elem_;
  std::vector<Vec2> z_;
  std::vector<double> w_;
  Gather gather_;
  double fix_ = 0, cur_ = 0;
  long version_ = 0;
  Eigen::SparseMatrix<double> extra_;
  bool factored_ = false;
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> chol_;
};

}  // namespace seamfit::opt
