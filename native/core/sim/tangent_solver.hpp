// Linear solves with the tangent stiffness H = d2E/dx2 of a simulator state,
// for the adjoint gradient (paper Eq. 18-19): H lambda = dF/dx.
//
// H is factorized by sparse LDL^T with a fill-reducing AMD ordering; the
// sparsity pattern of H is fixed by the mesh, so it is analysed once and every
// later factorization is numeric only. H need not be definite (compressed
// springs make it indefinite away from a strict minimum), only invertible: a
// shift eps * mean|diag H| * I pins the modes the model does not resist (a
// skirt turning about a frictionless body). A pivot that is zero or negligible
// against the largest one reports failure, and the caller shifts more.
#pragma once
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "sim/simulator.hpp"

namespace seamfit::sim {

class TangentSolver {
 public:
  explicit TangentSolver(Simulator& sim) : sim_(sim) {}
  // Factorizes H(x) (exact, or PSD-projected with psd) + shift * mean|diag H| * I;
  // false when a pivot vanishes (no solve is possible until a factorize succeeds).
  bool factorize(const double* x, bool psd, double shift);
  // out = (H + shift I)^-1 g, both 3n.
  void solve(const double* g, double* out) const;
  bool ready() const { return ready_; }
  Simulator& simulator() const { return sim_; }
  int factorizations() const { return factorizations_; }

 private:
  Simulator& sim_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  Eigen::SparseMatrix<double> Hs_;
  bool analysed_ = false;
  bool ready_ = false;
  int factorizations_ = 0;
};

}  // namespace seamfit::sim
