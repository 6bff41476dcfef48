// Preconditioned MINRES on the CPU with the GPU adjoint's scalar recurrence
// (sim/minres.hpp), over an assembled sparse matrix and 3x3 preconditioner
// blocks: the reference that checks the shared recurrence where no GPU is
// present (tests/sim/test_minres.py), and the same algorithm for a CPU caller.
#pragma once
#include <vector>

#include <Eigen/SparseCore>

#include "sim/math.hpp"
#include "sim/minres.hpp"

namespace seamfit::sim {

// Solves A lam = g from the start in lam (3n each); Minv: the inverse
// preconditioner blocks, one per vertex (symmetric positive definite).
// Returns the final state: status, iterations, phibar / bnorm.
MinresState minres_solve(const Eigen::SparseMatrix<double, Eigen::RowMajor>& A, const std::vector<Sym3>& Minv,
                         const double* g, double* lam, double tolerance, int max_iterations);

}  // namespace seamfit::sim
