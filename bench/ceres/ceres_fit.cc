// Ceres Solver side of the monohand lifting benchmark (bench/ceres/run.sh).
//
// Reads the problems the Rust driver wrote (camera, subject skeleton, joint
// limits, forward-kinematics check poses, then per case the observations and
// starting points), solves every problem with Ceres' Levenberg-Marquardt and
// automatic differentiation, and writes one line per problem.
//
// The model is a port of monohand-core's forward kinematics
// (crates/monohand-core/src/kinematics.rs, finger_chain): for each finger,
//   d_k = R(a, abduction) R(h, flex_1 + ... + flex_k) d,  p_k = p_{k-1} + d_k l_k,
// with a the abduction axis, h the rest flexion axis, d the rest bone
// direction, then X = R(q) p + t in the camera frame. Residuals are
// w_j (fx X/Z + cx - u_j, fy Y/Z + cy - v_j) with w_j = p_j^3 (0 for dropped
// joints), exactly the residuals of monohand's HandFitter. Ceres' cost is half
// the sum of squares; we report twice it, which is monohand's cost.
//
// Usage: ceres_fit PROBLEMS OUT [--repeats N] [--linear-solver cholesky|qr] [--verbose]

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr int kJoints = 21;
constexpr int kAngles = 20;
constexpr int kParams = 27;

struct Finger {
  double base[3], rest[3], flex[3], abd[3], len[3];
};

struct Model {
  double fx, fy, cx, cy;
  Finger fingers[5];
  double lower[kAngles], upper[kAngles];
};

[[noreturn]] void Die(const std::string& msg) {
  std::cerr << "ceres_fit: " << msg << std::endl;
  std::exit(2);
}

// v rotated about the unit axis k by angle th (Rodrigues).
template <typename T>
void RotateAbout(const double k[3], const T& th, const T v[3], T out[3]) {
  const T c = cos(th), s = sin(th);
  const T dot = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
  const T cr[3] = {k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2],
                   k[0] * v[1] - k[1] * v[0]};
  for (int i = 0; i < 3; ++i) out[i] = v[i] * c + cr[i] * s + k[i] * dot * (1.0 - c);
}

// The 21 joints in the camera frame. t: translation (3), q: quaternion x, y,
// z, w (Eigen order, as monohand's parameter vector), a: the 20 angles.
template <typename T>
void ForwardKinematics(const Model& m, const T* t, const T* q, const T* a, T out[kJoints][3]) {
  const T wxyz[4] = {q[3], q[0], q[1], q[2]};
  const T zero[3] = {T(0.0), T(0.0), T(0.0)};
  auto to_cam = [&](const T p[3], T x[3]) {
    ceres::QuaternionRotatePoint(wxyz, p, x);  // normalises q
    for (int i = 0; i < 3; ++i) x[i] += t[i];
  };
  to_cam(zero, out[0]);
  for (int f = 0; f < 5; ++f) {
    const Finger& g = m.fingers[f];
    const T* ang = a + 4 * f;  // base flexion, abduction, middle flexion, distal flexion
    T p[3] = {T(g.base[0]), T(g.base[1]), T(g.base[2])};
    const T d[3] = {T(g.rest[0]), T(g.rest[1]), T(g.rest[2])};
    to_cam(p, out[1 + 4 * f]);
    T flex = T(0.0);
    for (int k = 0; k < 3; ++k) {
      flex += ang[k == 0 ? 0 : k + 1];
      T bent[3], dir[3];
      RotateAbout(g.flex, flex, d, bent);
      RotateAbout(g.abd, ang[1], bent, dir);
      for (int i = 0; i < 3; ++i) p[i] += dir[i] * g.len[k];
      to_cam(p, out[2 + 4 * f + k]);
    }
  }
}

struct Observation {
  double u[kJoints], v[kJoints], w[kJoints];
};

struct ReprojectionResidual {
  ReprojectionResidual(const Model* m, const Observation* o) : m(m), o(o) {}
  template <typename T>
  bool operator()(const T* t, const T* q, const T* a, T* r) const {
    T x[kJoints][3];
    ForwardKinematics(*m, t, q, a, x);
    for (int j = 0; j < kJoints; ++j) {
      if (o->w[j] <= 0.0) {
        r[2 * j] = T(0.0);
        r[2 * j + 1] = T(0.0);
        continue;
      }
      r[2 * j] = o->w[j] * (m->fx * x[j][0] / x[j][2] + m->cx - o->u[j]);
      r[2 * j + 1] = o->w[j] * (m->fy * x[j][1] / x[j][2] + m->cy - o->v[j]);
    }
    return true;
  }
  const Model* m;
  const Observation* o;  // changed between solves; the problem is built once
};

// Whitespace-separated reader that checks every token.
struct Reader {
  std::ifstream in;
  std::string path;
  explicit Reader(const std::string& p) : in(p), path(p) {
    if (!in) Die("cannot open " + p);
  }
  std::string Word() {
    std::string s;
    if (!(in >> s)) Die("unexpected end of " + path);
    return s;
  }
  void Expect(const std::string& w) {
    const std::string s = Word();
    if (s != w) Die(path + ": expected '" + w + "', got '" + s + "'");
  }
  double Num() {
    const std::string s = Word();
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0' || !std::isfinite(v)) Die(path + ": bad number '" + s + "'");
    return v;
  }
  long Int() {
    const double v = Num();
    if (v != std::floor(v) || v < 0) Die(path + ": expected a count");
    return static_cast<long>(v);
  }
};

Model ReadModel(Reader& r) {
  Model m{};
  r.Expect("monohand-ceres-problems");
  r.Expect("1");
  r.Expect("camera");
  m.fx = r.Num();
  m.fy = r.Num();
  m.cx = r.Num();
  m.cy = r.Num();
  for (auto& g : m.fingers) {
    r.Expect("finger");
    for (double* arr : {g.base, g.rest, g.flex, g.abd, g.len})
      for (int i = 0; i < 3; ++i) arr[i] = r.Num();
  }
  r.Expect("lower");
  for (double& v : m.lower) v = r.Num();
  r.Expect("upper");
  for (double& v : m.upper) v = r.Num();
  return m;
}

// Checks the port against monohand's own forward kinematics.
void CheckForwardKinematics(Reader& r, const Model& m) {
  r.Expect("fkcheck");
  const long n = r.Int();
  double worst = 0.0;
  for (long i = 0; i < n; ++i) {
    double p[kParams], x[kJoints][3];
    for (double& v : p) v = r.Num();
    ForwardKinematics(m, p, p + 3, p + 7, x);
    for (int j = 0; j < kJoints; ++j)
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(x[j][k] - r.Num()));
  }
  std::cerr << "ceres_fit: forward kinematics vs monohand on " << n
            << " poses: max difference " << worst << " mm" << std::endl;
  if (n == 0 || !(worst <= 1e-9)) Die("the C++ forward kinematics does not match monohand's");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) Die("usage: ceres_fit PROBLEMS OUT [--repeats N] [--linear-solver cholesky|qr] [--verbose]");
  int repeats = 3;
  bool verbose = false;  // per-iteration progress of every solve on stdout
  ceres::LinearSolverType linear = ceres::DENSE_NORMAL_CHOLESKY;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--verbose") {
      verbose = true;
    } else if (a == "--linear-solver" && i + 1 < argc) {
      const std::string s = argv[++i];
      if (s == "qr") linear = ceres::DENSE_QR;
      else if (s == "cholesky") linear = ceres::DENSE_NORMAL_CHOLESKY;
      else Die("unknown linear solver " + s);
    } else {
      Die("unknown argument " + a);
    }
  }
  google::InitGoogleLogging(argv[0]);

  Reader r(argv[1]);
  const Model model = ReadModel(r);
  CheckForwardKinematics(r, model);

  std::ofstream out(argv[2]);
  if (!out) Die(std::string("cannot write ") + argv[2]);
  out.precision(17);

  // One problem, built once and reused for every solve: the observation the
  // residual reads and the parameter values are overwritten before each
  // Solve. This spares Ceres the problem construction per solve.
  Observation obs{};
  double t[3] = {0, 0, 500}, q[4] = {0, 0, 0, 1}, ang[kAngles] = {};
  ceres::Problem::Options popt;
  popt.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<ReprojectionResidual, 2 * kJoints, 3, 4, kAngles>(
          new ReprojectionResidual(&model, &obs)),
      nullptr, t, q, ang);
  problem.SetManifold(q, new ceres::EigenQuaternionManifold);
  for (int k = 0; k < kAngles; ++k) {
    problem.SetParameterLowerBound(ang, k, model.lower[k]);
    problem.SetParameterUpperBound(ang, k, model.upper[k]);
  }

  ceres::Solver::Options base;
  base.minimizer_type = ceres::TRUST_REGION;
  base.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  base.linear_solver_type = linear;
  base.num_threads = 1;
  base.logging_type = verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  base.minimizer_progress_to_stdout = verbose;
  // monohand: lambda_0 = 1e-3 relative to diag(J'J); Ceres' LM regularises
  // with diag(J'J) / radius, so radius_0 = 1 / lambda_0.
  base.initial_trust_region_radius = 1e3;
  // monohand: stop when an accepted step decreases the cost by <= 1e-9 of it.
  base.function_tolerance = 1e-9;
  // monohand has no gradient test.
  base.gradient_tolerance = 0.0;
  // monohand accepts any step that lowers the cost (Ceres' default needs
  // a ratio of actual to predicted decrease of 1e-3).
  base.min_relative_decrease = 1e-12;

  while (true) {
    std::string w;
    if (!(r.in >> w)) Die("missing 'end'");
    if (w == "end") break;
    if (w != "case") Die("expected 'case', got '" + w + "'");
    const std::string name = r.Word();
    const long max_iter = r.Int();
    const long count = r.Int();
    ceres::Solver::Options options = base;
    options.max_num_iterations = static_cast<int>(max_iter);
    std::cerr << "ceres_fit: case " << name << ": " << count << " problems, at most " << max_iter
              << " iterations per start" << std::endl;
    long failures = 0;
    for (long p = 0; p < count; ++p) {
      r.Expect("problem");
      const long frame = r.Int();
      const long nstarts = r.Int();
      for (int j = 0; j < kJoints; ++j) {
        obs.u[j] = r.Num();
        obs.v[j] = r.Num();
        obs.w[j] = r.Num();
      }
      std::vector<std::vector<double>> starts(nstarts, std::vector<double>(kParams));
      for (auto& s : starts)
        for (double& v : s) v = r.Num();

      double best_cost = std::numeric_limits<double>::infinity();
      double best[kParams] = {};
      long iterations = 0, unusable = 0;
      double wall_ns = std::numeric_limits<double>::infinity();
      double minimizer_ns = std::numeric_limits<double>::infinity();
      for (int rep = 0; rep < repeats; ++rep) {
        double rep_wall = 0.0, rep_min = 0.0;
        long rep_iter = 0, rep_unusable = 0;
        for (const auto& s : starts) {
          std::copy(s.begin(), s.begin() + 3, t);
          std::copy(s.begin() + 3, s.begin() + 7, q);
          std::copy(s.begin() + 7, s.end(), ang);
          // monohand: stop when no step component exceeds 1e-7 (mm or rad).
          // Ceres: |step|_2 <= tol (|x|_2 + tol); tol = 1e-7 / |x_0| gives
          // the same 1e-7 threshold (as an L2 norm) at the start.
          double xn = 0.0;
          for (double v : s) xn += v * v;
          options.parameter_tolerance = 1e-7 / std::sqrt(xn);
          ceres::Solver::Summary summary;
          const auto t0 = std::chrono::steady_clock::now();
          ceres::Solve(options, &problem, &summary);
          const auto t1 = std::chrono::steady_clock::now();
          rep_wall += std::chrono::duration<double, std::nano>(t1 - t0).count();
          rep_min += summary.minimizer_time_in_seconds * 1e9;
          rep_iter += summary.num_successful_steps + summary.num_unsuccessful_steps;
          if (!summary.IsSolutionUsable()) {
            ++rep_unusable;
            if (rep == 0) std::cerr << summary.FullReport() << std::endl;
            continue;
          }
          if (rep == 0 && 2.0 * summary.final_cost < best_cost) {
            best_cost = 2.0 * summary.final_cost;
            std::copy(t, t + 3, best);
            std::copy(q, q + 4, best + 3);
            std::copy(ang, ang + kAngles, best + 7);
          }
        }
        wall_ns = std::min(wall_ns, rep_wall);
        minimizer_ns = std::min(minimizer_ns, rep_min);
        if (rep == 0) {
          iterations = rep_iter;
          unusable = rep_unusable;
        }
      }
      failures += unusable;
      out << name << ' ' << frame << ' ' << nstarts << ' ' << wall_ns << ' ' << minimizer_ns << ' '
          << iterations << ' ' << best_cost;
      for (double v : best) out << ' ' << v;
      out << '\n';
    }
    if (failures > 0) std::cerr << "ceres_fit: " << failures << " solves unusable" << std::endl;
  }
  return 0;
}
