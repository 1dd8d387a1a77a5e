// Assembly benchmark (issue 7): Jacobian and residual assembly of each muscle
// model against a plain compressible Neo-Hooke form on the fusiform mesh, same
// element and quadrature; for WKM and GIANT also the quadrature-point kernel
// update (omega_a and its derivatives), which runs before every residual.
//
//   bench-assembly [--refinement 1|2|4] [--cell hex|tet] [--degree 1|2] [--fbar]
//                  [--repetitions N] [--amplitude A] [--models ...] [--json FILE]
//
// On a shared machine wall times are noisy; for load-independent numbers run it
// under callgrind (one instrumented call per operation, dumped per label):
//   valgrind --tool=callgrind --instr-atstart=no bench-assembly --repetitions 1
// (benchmarks/run_benchmarks.py instructions does this and parses the dumps).
//
// The state is a smooth, isochoric displacement that vanishes at both ends
// (axial stretch 1 +- 0.1 A with lateral contraction and a twist, see
// deformation()) at time factor 1, so every activation term is live and the
// stiff coupled penalty of WKM/GIANT/COMBI stays finite.  Each operation is repeated N times after one
// warm-up; the table shows the median (and min/max in the JSON).  The Neo-Hooke
// forms are built here from the compiled "neohooke" variant with the same
// displacement space and coefficients as MuscleProblem (MuscleProblem is tied
// to a muscle model's ParameterSet and cannot build it).
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <fem/elements/fibres.h>
#include <fem/elements/muscle_problem.h>
#include <form_registry.h>
#include <io/gmsh_mesh.h>
#include <loadcases/load_case.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <dolfinx/common/MPI.h>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/cell_types.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <petscmat.h>
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else // no valgrind headers: instruction counting is off
#define RUNNING_ON_VALGRIND 0
#define CALLGRIND_ZERO_STATS
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#define CALLGRIND_DUMP_STATS_AT(label) (void)(label)
#endif
#include <xtensor/xarray.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
using Clock = std::chrono::steady_clock;

double cpu_seconds()
{
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

struct Timing
{
  std::vector<double> samples, cpu; ///< wall and process CPU seconds
  double cpu_median() const
  {
    std::vector<double> s = cpu;
    if (s.empty())
      return 0;
    std::sort(s.begin(), s.end());
    const std::size_t n = s.size();
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
  }
  double median() const
  {
    if (samples.empty())
      return 0;
    std::vector<double> s = samples;
    std::sort(s.begin(), s.end());
    const std::size_t n = s.size();
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
  }
  double min() const
  {
    return samples.empty() ? 0 : *std::min_element(samples.begin(), samples.end());
  }
  double max() const
  {
    return samples.empty() ? 0 : *std::max_element(samples.begin(), samples.end());
  }
};

/// Time f (seconds, max over ranks) `repetitions` times after one warm-up:
/// wall time and the process CPU time (less sensitive to other processes on a
/// shared machine: time spent descheduled is not counted).
template <typename F>
Timing time_it(F&& f, int repetitions, MPI_Comm comm)
{
  Timing t;
  f();
  for (int i = 0; i < repetitions; ++i)
  {
    MPI_Barrier(comm);
    const auto start = Clock::now();
    const double cpu_start = cpu_seconds();
    f();
    double local[2] = {std::chrono::duration<double>(Clock::now() - start).count(),
                       cpu_seconds() - cpu_start};
    double global[2];
    MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_MAX, comm);
    t.samples.push_back(global[0]);
    t.cpu.push_back(global[1]);
  }
  return t;
}

std::array<double, 3> loadavg()
{
  std::array<double, 3> l{-1, -1, -1};
  std::ifstream f("/proc/loadavg");
  f >> l[0] >> l[1] >> l[2];
  return l;
}

/// The benchmark state: an exactly isochoric map of the continuum (so the
/// stiff coupled penalty stays finite), zero at z = 0 and z = 100 mm: fibre-wise
/// stretch lambda(z) = 1 + a sin(2 pi z / L), cross-sections scaled by
/// 1/sqrt(lambda) and twisted by b sin(pi z / L) (shear for BLE's B1, B2):
///   x' = r(z) R(theta(z)) x,  z' = g(z),  g' = lambda,  r = lambda^(-1/2),
/// so det F = r^2 g' = 1.  `amplitude` scales a = 0.1 and b = 0.05.
xt::xarray<double> deformation(const xt::xtensor<double, 2>& x, double amplitude)
{
  xt::xarray<double> u = xt::zeros<double>({std::size_t(3), x.shape(1)});
  const double pi = M_PI, L = 100, a = 0.1 * amplitude, b = 0.05 * amplitude;
  for (std::size_t i = 0; i < x.shape(1); ++i)
  {
    const double X = x(0, i), Y = x(1, i), Z = x(2, i);
    const double lambda = 1 + a * std::sin(2 * pi * Z / L);
    const double g = Z + a * L / (2 * pi) * (1 - std::cos(2 * pi * Z / L));
    const double r = 1 / std::sqrt(lambda), theta = b * std::sin(pi * Z / L);
    const double c = std::cos(theta), s = std::sin(theta);
    u(0, i) = r * (c * X - s * Y) - X;
    u(1, i) = r * (s * X + c * Y) - Y;
    u(2, i) = g - Z;
  }
  return u;
}

/// What one measurement needs: residual and Jacobian forms on a space, the
/// displacement to set, and (optionally) the kernel update.
struct Subject
{
  std::string name;
  std::shared_ptr<const fem::Form<double>> residual, jacobian;
  std::shared_ptr<fem::Function<double>> u;
  std::function<KernelStatus()> update; // empty: no kernel
};

struct Result
{
  std::string model;
  Timing jacobian, residual, kernel;
  double residual_norm = 0;
  std::int64_t kernel_failures = 0;
};

/// Under `valgrind --tool=callgrind --instr-atstart=no`: one instrumented call
/// of f, dumped as "LABEL" (instruction counts do not depend on the load of a
/// shared machine).  Outside valgrind: nothing.
template <typename F>
void count_instructions(F&& f, const std::string& label)
{
  if (!RUNNING_ON_VALGRIND)
    return;
  CALLGRIND_ZERO_STATS;
  CALLGRIND_START_INSTRUMENTATION;
  f();
  CALLGRIND_STOP_INSTRUMENTATION;
  CALLGRIND_DUMP_STATS_AT(label.c_str());
}

Result measure(const Subject& s, int repetitions, MPI_Comm comm)
{
  Result r;
  r.model = s.name;
  Mat A = fem::petsc::create_matrix(*s.jacobian, "aij");
  la::Vector<double> b(s.residual->function_spaces()[0]->dofmap()->index_map,
                       s.residual->function_spaces()[0]->dofmap()->index_map_bs());
  if (s.update)
  {
    r.kernel_failures = s.update().failures;
    r.kernel = time_it([&] { s.update(); }, repetitions, comm);
    count_instructions([&] { s.update(); }, s.name + ":kernel");
  }
  auto residual = [&]
  {
    std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
    fem::assemble_vector<double>(b.mutable_array(), *s.residual);
    b.scatter_rev(std::plus<double>());
  };
  r.residual = time_it(residual, repetitions, comm);
  count_instructions(residual, s.name + ":residual");
  r.residual_norm = la::norm(b, la::Norm::l2);
  auto jacobian = [&]
  {
    MatZeroEntries(A);
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *s.jacobian, {});
    MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  };
  r.jacobian = time_it(jacobian, repetitions, comm);
  count_instructions(jacobian, s.name + ":jacobian");
  MatDestroy(&A);
  return r;
}
} // namespace

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    int refinement = 1, degree = 1, repetitions = 7;
    bool fbar = false;
    double amplitude = 1.0;
    std::string cell = "hex", json_path;
    std::vector<std::string> models; // default: the paper's (DEFAULT_FOR "paper")
    for (const Model& m : paper_models())
      models.push_back(m.name());
    CLI::App app{"Assembly time of the muscle models against compressible Neo-Hooke on "
                 "the fusiform mesh (median of N repetitions)."};
    app.add_option("--refinement", refinement, "fusiform refinement n")->capture_default_str();
    app.add_option("--cell", cell, "hex or tet")->capture_default_str();
    app.add_option("--degree", degree, "displacement degree 1 or 2")->capture_default_str();
    app.add_flag("--fbar", fbar, "the muscle models on F-bar hexahedra (degree 1)");
    app.add_option("--repetitions", repetitions, "timed repetitions per operation")
        ->capture_default_str();
    app.add_option("--amplitude", amplitude, "scale of the benchmark displacement")
        ->capture_default_str();
    app.add_option("--models", models, "muscle models to time")->capture_default_str();
    app.add_option("--json", json_path, "write the numbers to this JSON file");
    if (!parse_command_line(app, std::move(args)))
      return 0;
    if (cell != "hex" and cell != "tet")
      throw InputError("--cell '" + cell + "': allowed: hex, tet");
    if (repetitions < 1)
      throw InputError("--repetitions must be at least 1");

    const auto load_before = loadavg();
    MPI_Comm comm = MPI_COMM_WORLD;
    const GmshMesh gm
        = read_gmsh(comm, std::string(MUSCLE_SOURCE_DIR) + "/meshes/fusiform.geo",
                    {{"refinement", refinement}, {"tet", cell == "tet"}});
    auto mesh = gm.mesh;
    auto f = [amplitude](const xt::xtensor<double, 2>& x) { return deformation(x, amplitude); };

    std::vector<std::unique_ptr<MuscleProblem>> problems;
    std::vector<Subject> subjects;
    LaplaceFibres fibres;
    for (const std::string& name : models)
    {
      ParameterSet parameters(parse_model(name));
      auto p = std::make_unique<MuscleProblem>(mesh, parameters,
                                               Discretisation{degree, -1, -1, fbar});
      if (!fibres.fibre)
        fibres = laplace_fibres(mesh, *gm.facet_tags, gm.surface("origin"),
                                gm.surface("insertion"), p->fibre()->function_space());
      p->set_fibre(*fibres.fibre);
      p->set_time_factor(1.0);
      p->u()->interpolate(f);
      MuscleProblem* raw = p.get();
      Subject s{name, p->residual(), p->jacobian(), p->u(), {}};
      if (p->has_activation_kernel())
        s.update = [raw] { return raw->update_activation(); };
      subjects.push_back(s);
      problems.push_back(std::move(p));
    }

    // The yardstick: compressible Neo-Hooke, same space, element and quadrature
    const std::string cell_name = mesh::to_string(mesh->topology().cell_type());
    const forms::FeVariant& nh = forms::find_fe_variant("neohooke", cell_name, degree, -1);
    auto V = std::make_shared<fem::FunctionSpace>(
        fem::create_functionspace(nh.function_space, "u", mesh));
    auto u = std::make_shared<fem::Function<double>>(V);
    u->interpolate(f);
    std::map<std::string, std::shared_ptr<const fem::Function<double>>> coefficients
        = {{"u", u}};
    if (!problems.empty())
    {
      coefficients["fibre"] = problems.front()->fibre();
      coefficients["activation_scale"] = problems.front()->activation_scale();
    }
    std::map<std::string, std::shared_ptr<const fem::Constant<double>>> constants
        = {{"E", std::make_shared<fem::Constant<double>>(1.0)},
           {"nu", std::make_shared<fem::Constant<double>>(0.45)}};
    auto nh_residual = std::make_shared<fem::Form<double>>(
        fem::create_form<double>(*nh.residual, {V}, coefficients, constants, {}));
    auto nh_jacobian = std::make_shared<fem::Form<double>>(
        fem::create_form<double>(*nh.jacobian, {V, V}, coefficients, constants, {}));
    subjects.insert(subjects.begin(), Subject{"neohooke", nh_residual, nh_jacobian, u, {}});

    const std::int64_t unknowns = V->dofmap()->index_map->size_global() * 3;
    if (is_root())
      std::printf("fusiform n=%d %s degree %d%s (quadrature degree %d): %lld cells, %lld "
                  "unknowns, %d ranks, %d repetitions, load average %.2f\n",
                  refinement, cell.c_str(), degree, fbar ? " F-bar" : "", nh.quadrature_degree,
                  static_cast<long long>(gm.num_cells), static_cast<long long>(unknowns),
                  dolfinx::MPI::size(comm), repetitions, load_before[0]);

    std::vector<Result> results;
    for (const Subject& s : subjects)
      results.push_back(measure(s, repetitions, comm));
    const auto load_after = loadavg();

    const Result& ref = results.front();
    const double ref_newton = ref.jacobian.median() + ref.residual.median();
    const double ref_newton_cpu = ref.jacobian.cpu_median() + ref.residual.cpu_median();
    nlohmann::json out = {{"refinement", refinement}, {"cell", cell}, {"degree", degree},
                          {"fbar", fbar},
                          {"quadrature_degree", nh.quadrature_degree},
                          {"cells", gm.num_cells}, {"unknowns", unknowns},
                          {"ranks", dolfinx::MPI::size(comm)}, {"repetitions", repetitions},
                          {"amplitude", amplitude},
                          {"loadavg_before", load_before}, {"loadavg_after", load_after},
                          {"models", nlohmann::json::array()}};
    if (is_root())
    {
      std::printf("%-9s %12s %12s %11s %7s %7s %10s %10s %7s %5s  %s\n", "model",
                  "jacobian[ms]", "residual[ms]", "kernel[ms]", "J/NH", "r/NH", "(J+r+k)/NH",
                  "cpu-ratio", "target", "met", "|r|");
    }
    for (const Result& r : results)
    {
      double target = 0; // issue 18: the F-bar element of any model at most 2.5x plain Q1 NH
      // the paper's models: 1.5x (2x with an omega kernel: WKM, GIANT) on plain elements
      const auto& paper = paper_models();
      const auto law = std::find_if(paper.begin(), paper.end(),
                                    [&](const Model& p) { return p.name() == r.model; });
      if (law != paper.end())
        target = fbar ? 2.5 : law->has_activation_kernel() ? 2.0 : 1.5;
      const double jr = r.jacobian.median() / ref.jacobian.median();
      const double rr = r.residual.median() / ref.residual.median();
      const double nr
          = (r.jacobian.median() + r.residual.median() + r.kernel.median()) / ref_newton;
      const double ncpu = (r.jacobian.cpu_median() + r.residual.cpu_median()
                           + r.kernel.cpu_median())
                          / ref_newton_cpu;
      nlohmann::json m = {
          {"model", r.model},
          {"jacobian_median", r.jacobian.median()}, {"jacobian_min", r.jacobian.min()},
          {"jacobian_max", r.jacobian.max()},
          {"residual_median", r.residual.median()}, {"residual_min", r.residual.min()},
          {"residual_max", r.residual.max()},
          {"kernel_median", r.kernel.median()}, {"kernel_min", r.kernel.min()},
          {"kernel_max", r.kernel.max()},
          {"jacobian_ratio", jr}, {"residual_ratio", rr},
          {"residual_with_kernel_ratio",
           (r.residual.median() + r.kernel.median()) / ref.residual.median()},
          {"newton_ratio", nr},
          {"jacobian_cpu_median", r.jacobian.cpu_median()},
          {"residual_cpu_median", r.residual.cpu_median()},
          {"kernel_cpu_median", r.kernel.cpu_median()},
          {"jacobian_cpu_ratio", r.jacobian.cpu_median() / ref.jacobian.cpu_median()},
          {"residual_cpu_ratio", r.residual.cpu_median() / ref.residual.cpu_median()},
          {"newton_cpu_ratio", ncpu},
          {"residual_norm", r.residual_norm},
          {"kernel_failures", r.kernel_failures}};
      if (target > 0)
      {
        m["target"] = target;
        m["target_met"] = nr <= target;
      }
      else
      {
        m["target"] = nullptr;
        m["target_met"] = nullptr;
      }
      out["models"].push_back(m);
      if (is_root())
        std::printf("%-9s %12.2f %12.2f %11.2f %7.2f %7.2f %10.2f %10.2f %7s %5s  %.3e%s\n",
                    r.model.c_str(), 1e3 * r.jacobian.median(), 1e3 * r.residual.median(),
                    1e3 * r.kernel.median(), jr, rr, nr, ncpu,
                    target > 0 ? (std::to_string(target).substr(0, 3) + "x").c_str() : "-",
                    target > 0 ? (nr <= target ? "yes" : "NO") : "-", r.residual_norm,
                    r.kernel_failures ? " (kernel failures!)" : "");
    }
    if (is_root())
    {
      std::printf("(J+r+k)/NH: one Newton iteration's assembly (Jacobian + residual + kernel "
                  "update) over Neo-Hooke's Jacobian + residual, wall-time medians; cpu-ratio: "
                  "the same from process CPU time; target met on the wall ratio; load "
                  "average after %.2f\n",
                  load_after[0]);
      if (!json_path.empty())
        std::ofstream(json_path) << out.dump(1) << "\n";
    }
    return 0;
  });
}
