#include "sim/minres_cpu.hpp"

#include <stdexcept>

namespace seamfit::sim {

namespace {

using Vec = Eigen::VectorXd;

// y = M^-1 r, block by block.
void apply_blocks(const std::vector<Sym3>& Minv, const Vec& r, Vec& y) {
  for (size_t i = 0; i < Minv.size(); ++i) {
    const Vec3 v = Minv[i] * make_vec3(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
    y[3 * i] = v.x;
    y[3 * i + 1] = v.y;
    y[3 * i + 2] = v.z;
  }
}

}  // namespace

MinresState minres_solve(const Eigen::SparseMatrix<double, Eigen::RowMajor>& A, const std::vector<Sym3>& Minv,
                         const double* g, double* lam, double tolerance, int max_iterations) {
  const Eigen::Index n3 = A.rows();
  if (A.cols() != n3 || Eigen::Index(3 * Minv.size()) != n3)
    throw std::invalid_argument("minres_solve: A must be square with one 3x3 block of Minv per vertex");
  const Eigen::Map<const Vec> gv(g, n3);
  Eigen::Map<Vec> x(lam, n3);
  // The vector steps of sim/minres.hpp's comment, in the same order as the GPU's.
  Vec r1 = gv - A * x, r2 = r1, y(n3), v = Vec::Zero(n3), w = Vec::Zero(n3), w2 = Vec::Zero(n3), t(n3), mg(n3);
  apply_blocks(Minv, r1, y);
  apply_blocks(Minv, gv, mg);
  MinresState s;
  s.tol = tolerance;
  s.max_it = max_iterations;
  s.gnorm2 = gv.squaredNorm();
  minres_start(s, r1.dot(y), gv.dot(mg));
  while (!s.done) {
    if (s.pending) {
      const Vec wn = s.denom * (v - s.oldeps * w2 - s.delta * w);
      w2 = w;
      w = wn;
      x += s.phi * wn;
    }
    v = y / s.beta;
    t = A * v;
    if (s.oldb > 0) t -= (s.beta / s.oldb) * r1;
    s.alfa = v.dot(t);
    s.pending = 0;
    t -= (s.alfa / s.beta) * r2;
    r1 = r2;
    r2 = t;
    apply_blocks(Minv, r2, y);
    minres_rotate(s, r2.dot(y));
  }
  if (s.pending) {
    const Vec wn = s.denom * (v - s.oldeps * w2 - s.delta * w);
    x += s.phi * wn;
    s.pending = 0;
  }
  s.rnorm2 = (gv - A * x).squaredNorm();
  return s;
}

}  // namespace seamfit::sim
