// Implicit (backward) Euler on the particle system (paper 001 section 1; the block-sparse solve of
// paper 002 section 6.5). With velocities v = (x - x_prev) / dt, damping rate kappa and the forces
// linearised around the current positions, f(x + dt v') ~ f + K dt v' (K = df/dx from the forces
// that provide it, with what they found for the step held fixed; the others stay explicit), the new
// velocity solves
//   (M (1 + dt kappa) - dt^2 K) v' = M v + dt f,      x' = x + dt v'.
// The matrix has one 3x3 block per vertex and one per neighbour; it is symmetric positive definite
// when K is symmetric negative semi-definite, so conjugate gradients with a block-Jacobi
// preconditioner (each vertex's 3x3 diagonal block inverted) solve it.
#include "sinew/core/registry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sinew {

namespace {
// Dot products summed in fixed blocks, then in order: the result does not depend on the threads.
class BlockSums {
public:
  template <class Term>
  double sum(const Executor& ex, Index n, Term&& term) {
    const Index blocks = (n + kBlock - 1) / kBlock;
    partial_.assign(blocks, 0.0);
    ex.forEach(blocks, [&](Index b) {
      double s = 0.0;
      for (Index i = b * kBlock, e = std::min(n, i + kBlock); i < e; ++i) s += term(i);
      partial_[b] = s;
    }, 1);
    double s = 0.0;
    for (double p : partial_) s += p;
    return s;
  }

private:
  static constexpr Index kBlock = 4096;
  std::vector<double> partial_;
};

class ImplicitEuler final : public PreviousPositionIntegrator {
public:
  Requirements requirements() const override {
    Requirements r{{Attribute::PreviousPosition, Attribute::Force, Attribute::Mass}, false};
    r.jacobian = true;
    return r;
  }

  void step(IntegratorContext& ctx) override {
    MeshStore& s = ctx.store;
    const Executor& ex = ctx.executor;
    const float h = ctx.params.getf(0, ctx.params.indexOf("time_step"));
    const float kappa = ctx.params.getf(0, ctx.params.indexOf("damping_rate"));
    const double tolerance = ctx.params.get(0, ctx.params.indexOf("cg_tolerance"));
    const int maxIterations = static_cast<int>(ctx.params.get(0, ctx.params.indexOf("cg_max_iterations")));
    const Index n = s.vertexCount();
    const auto mass = s.masses();  // read before positions are marked stale
    const auto f = s.forces();
    const auto nb = s.neighbours();
    const JacobianBlocks& J = *ctx.jacobian;
    auto prev = s.previousPositions();
    const auto x0 = s.positions();

    assemble(ex, n, nb, mass, J, h, kappa);
    b_.resize(n), v_.resize(n), r_.resize(n), z_.resize(n), p_.resize(n), ap_.resize(n);
    ex.forEach(n, [&](Index i) {
      v_[i] = (x0[i] - prev[i]) / h;  // the current velocity: the first guess
      b_[i] = mass[i] * v_[i] + h * f[i];
    }, 4096);
    solve(ex, n, nb, tolerance, maxIterations);

    auto x = s.positionsForWrite();
    ex.forEach(n, [&](Index i) {
      prev[i] = x[i];
      x[i] += h * v_[i];
    }, 4096);
  }

private:
  // A = M (1 + h kappa) - h^2 K, with each neighbour block averaged with its mirror so that A is
  // exactly symmetric even when a force's blocks are only symmetric up to rounding.
  void assemble(const Executor& ex, Index n, std::span<const std::array<Index, 3>> nb, std::span<const float> mass,
                const JacobianBlocks& J, float h, float kappa) {
    diagInverse_.resize(n), diag_.resize(n), off_.resize(n);
    const float h2 = h * h;
    ex.forEach(n, [&](Index v) {
      diag_[v] = mass[v] * (1.0f + h * kappa) * Mat3::Identity() - h2 * J.self[v];
      diagInverse_[v] = diag_[v].inverse();
      for (int k = 0; k < 3; ++k) {
        const Index u = nb[v][k];
        int back = 0;
        while (back < 2 && nb[u][back] != v) ++back;
        off_[v][k] = -0.5f * h2 * (J.neighbour[v][k] + J.neighbour[u][back].transpose());
      }
    }, 2048);
  }

  void multiply(const Executor& ex, Index n, std::span<const std::array<Index, 3>> nb, const std::vector<Vec3>& in,
                std::vector<Vec3>& out) {
    ex.forEach(n, [&](Index v) {
      Vec3 y = diag_[v] * in[v];
      for (int k = 0; k < 3; ++k) y += off_[v][k] * in[nb[v][k]];
      out[v] = y;
    }, 2048);
  }

  // Preconditioned conjugate gradients from the guess in v_.
  void solve(const Executor& ex, Index n, std::span<const std::array<Index, 3>> nb, double tolerance,
             int maxIterations) {
    multiply(ex, n, nb, v_, ap_);
    ex.forEach(n, [&](Index i) {
      r_[i] = b_[i] - ap_[i];
      z_[i] = diagInverse_[i] * r_[i];
      p_[i] = z_[i];
    }, 4096);
    const double bNorm = std::sqrt(sums_.sum(ex, n, [&](Index i) { return double(b_[i].squaredNorm()); }));
    double rz = sums_.sum(ex, n, [&](Index i) { return double(r_[i].dot(z_[i])); });
    if (!std::isfinite(bNorm) || !std::isfinite(rz)) {
      // A non-finite force or Jacobian: make the step non-finite too, so the guard sees it (keeping
      // the old velocity would coast on silently).
      std::fill(v_.begin(), v_.end(), Vec3::Constant(std::numeric_limits<float>::quiet_NaN()));
      return;
    }
    for (int it = 0; it < maxIterations; ++it) {
      const double rNorm = std::sqrt(sums_.sum(ex, n, [&](Index i) { return double(r_[i].squaredNorm()); }));
      if (!(rNorm > tolerance * bNorm)) break;  // converged (or b = 0)
      multiply(ex, n, nb, p_, ap_);
      const double pAp = sums_.sum(ex, n, [&](Index i) { return double(p_[i].dot(ap_[i])); });
      if (!(pAp > 0.0) || !std::isfinite(pAp)) break;  // not positive definite: keep the last iterate
      const float alpha = static_cast<float>(rz / pAp);
      ex.forEach(n, [&](Index i) {
        v_[i] += alpha * p_[i];
        r_[i] -= alpha * ap_[i];
        z_[i] = diagInverse_[i] * r_[i];
      }, 4096);
      const double rzNext = sums_.sum(ex, n, [&](Index i) { return double(r_[i].dot(z_[i])); });
      const float beta = static_cast<float>(rzNext / rz);
      rz = rzNext;
      ex.forEach(n, [&](Index i) { p_[i] = z_[i] + beta * p_[i]; }, 4096);
    }
  }

  std::vector<Mat3> diag_, diagInverse_;
  std::vector<std::array<Mat3, 3>> off_;
  std::vector<Vec3> b_, v_, r_, z_, p_, ap_;
  BlockSums sums_;
};
}  // namespace

void registerImplicitEuler(Registry& registry) {
  registry.addIntegrator(
      {"implicit_euler",
       "backward Euler, (M (1 + dt kappa) - dt^2 df/dx) v' = M v + dt f, solved by block-Jacobi "
       "preconditioned conjugate gradients; forces without a Jacobian stay explicit",
       {{"time_step", 2.0, 1e-4, 100.0, "", "dt", false},
        {"damping_rate", 3.0, 0.0, 1000.0, "1/time",
         "kappa: each step divides the velocity by 1 + dt kappa (3 matches damped_verlet's default at dt 0.5)",
         false},
        {"cg_tolerance", 1e-4, 1e-10, 0.1, "", "conjugate gradients stop at this residual relative to the right side",
         false},
        {"cg_max_iterations", 100, 1, 1000, "", "conjugate gradient iterations per step at most", false}},
       [] { return std::make_unique<ImplicitEuler>(); }});
}

}  // namespace sinew
