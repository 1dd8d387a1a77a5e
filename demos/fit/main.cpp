// Material parameter identification from stress-stretch data of the paper's
// load cases (issue 5): bounded nonlinear least squares with Ceres (trust
// region), the model side being the exact homogeneous response P_exact.
//
//   fit --model ble --data a.csv b.csv [--start FILE] [--set NAME=VALUE ...]
//       [--free N1,N2,...] [--fix N1,...] [--bounds NAME=LO:HI ...]
//       [--weight CASE[:state]=W ...] [--scale-curves] [--out DIR] [--png FILE] [--no-plot] [--strict]
//
//   fit --model combi --print-parameters [--start FILE] [--set ...]
//
//   fit --model wkm --synthesize FILE [--case ...] [--state ...] [--stretch A:B:N]
//       [--shear A:B:N] [--kinematics exact|paper] [--noise REL] [--seed N] [--set ...]
//
// Output (in --out): MODEL.params (name=value lines, exactly ParameterSet::to_text(),
// so `loadcases --set $(cat MODEL.params)` reads it), report.txt (also printed),
// fit.json, fit_points.csv, fit_curves.csv and fit.png.
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <fit/fit.h>
#include <io/plotting.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>

using namespace muscle;
using namespace muscle::fit;

namespace
{
std::vector<std::string> split_list(const std::string& text)
{
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= text.size())
  {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start)
      out.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

double parse_number(const std::string& text, const std::string& what)
{
  // bounds may be infinite
  const auto v = parse_real(text, false);
  if (!v)
    throw InputError(what + ": '" + text + "' is not a number");
  return *v;
}

std::pair<std::string, std::string> split_assignment(const std::string& a,
                                                     const std::string& option,
                                                     const std::string& form)
{
  const auto eq = a.find('=');
  if (eq == std::string::npos or eq == 0)
    throw InputError(option + ": expected " + form + ", got '" + a + "'");
  return {a.substr(0, eq), a.substr(eq + 1)};
}

void write_text(const std::filesystem::path& path, const std::string& text)
{
  std::ofstream out(path);
  if (!out)
    throw InputError("cannot write " + path.string());
  out << text;
}

/// Data points with the fitted model, and dense fitted curves per case/state.
void write_plot_data(const std::filesystem::path& dir, const FitResult& r,
                     const std::vector<DataPoint>& data)
{
  std::ofstream points(dir / "fit_points.csv");
  points << "case,state,stretch,stress,P_exact,file,line\n" << std::setprecision(12);
  for (std::size_t i = 0; i < data.size(); ++i)
    points << to_string(data[i].load_case) << "," << to_string(data[i].state) << ","
           << data[i].control << "," << data[i].stress << "," << r.model[i] << ","
           << data[i].file << "," << data[i].line << "\n";
  std::ofstream curves(dir / "fit_curves.csv");
  curves << "case,state,stretch,P_exact\n" << std::setprecision(12);
  for (const CurveErrors& e : r.errors)
  {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const DataPoint& d : data)
      if (CurveKey{d.load_case, d.state} == e.key)
      {
        lo = std::min(lo, d.control);
        hi = std::max(hi, d.control);
      }
    const int n = 61;
    for (int k = 0; k < n; ++k)
    {
      const double s = lo + (hi - lo) * k / (n - 1);
      try
      {
        const double v = model_curve(r.fitted, e.key, {s}).front();
        curves << to_string(e.key.load_case) << "," << to_string(e.key.state) << "," << s
               << "," << v << "\n";
      }
      catch (const std::exception&)
      {
      }
    }
  }
}

int synthesize_main(const ParameterSet& p, const std::string& file,
                    const std::string& case_list, const std::string& state_list,
                    const std::string& stretch_spec, const std::string& shear_spec,
                    const std::string& kinematics, double noise, unsigned seed)
{
  std::vector<LoadCase> cases;
  if (case_list == "all")
    cases = all_load_cases();
  else
    for (const std::string& c : split_list(case_list))
      cases.push_back(parse_load_case(c));
  std::vector<MuscleState> states;
  if (state_list == "both")
    states = {MuscleState::passive, MuscleState::active};
  else
    for (const std::string& s : split_list(state_list))
      states.push_back(parse_state_name(s));
  std::vector<CurveKey> curves;
  for (MuscleState s : states)
    for (LoadCase c : cases)
      curves.push_back({c, s});
  const std::vector<double> stretches = parse_range(stretch_spec, "--stretch");
  std::vector<double> shears;
  if (!shear_spec.empty())
    shears = parse_range(shear_spec, "--shear");
  else
    for (double s : stretches)
      shears.push_back(s - 1);
  if (kinematics != "exact" and kinematics != "paper")
    throw InputError("--kinematics: '" + kinematics + "' is not allowed"
                     + did_you_mean(kinematics, {"exact", "paper"}) + "; allowed: exact, paper");
  if (!(noise >= 0))
    throw InputError("--noise must be >= 0");
  const auto points = synthesize(p, curves, stretches, shears,
                                 kinematics == "paper" ? Kinematics::paper : Kinematics::exact,
                                 noise, seed);
  write_data_csv(file, points);
  std::printf("wrote %zu points (%zu curves, %s kinematics, noise %g x max|P|) to %s\n",
              points.size(), curves.size(), kinematics.c_str(), noise, file.c_str());
  return 0;
}
} // namespace

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    CLI::App app{"Fit the material parameters of a muscle model to stress-stretch data of "
                 "the paper's load cases (bounded least squares, Ceres trust region), or "
                 "--synthesize such data from known parameters."};
    std::string model_name, start_file, free_list, fix_list, out = "fit", png, synth_file;
    std::vector<std::string> data_files, assignments, bound_specs, weight_specs;
    bool no_plot = false, strict = false, progress = false, quiet = false, print = false,
         scale_curves = false;
    int max_iterations = 200;
    std::string case_list = "all", state_list = "passive", stretch_spec = "0.8:1.2:9",
                shear_spec, kinematics = "exact";
    double noise = 0;
    unsigned seed = 1;
    std::vector<std::string> laws;
    for (const Model& m : all_models())
      laws.push_back(m.name());
    app.add_option("--model", model_name, "the law: " + join(laws))->required();
    app.add_option("--data", data_files, "CSV files with columns case,state,stretch,stress")
        ->take_all();
    app.add_option("--start", start_file,
                   "parameter file (name=value lines) with start values");
    app.add_option("--set", assignments, "NAME=VALUE: start value (or fixed value)")
        ->take_all();
    app.add_option("--free", free_list,
                   "comma list of the parameters to fit (default: the paper's)");
    app.add_option("--fix", fix_list, "comma list of parameters to hold fixed");
    app.add_option("--bounds", bound_specs, "NAME=LO:HI (within the admissible range)")
        ->take_all();
    app.add_option("--weight", weight_specs,
                   "CASE=W or CASE:state=W: weight of the squared residuals (default 1)")
        ->take_all();
    app.add_flag("--scale-curves", scale_curves,
                 "divide each curve's residuals by its largest |stress| (relative misfit; "
                 "default: absolute kPa as in the paper)");
    app.add_option("--out", out, "output directory")->capture_default_str();
    app.add_option("--png", png, "PNG of data and fitted curves (default: OUT/fit.png)");
    app.add_flag("--no-plot", no_plot, "no PNG");
    app.add_flag("--strict", strict,
                 "exit with status 3 if a free parameter is not (well) determined");
    app.add_option("--max-iterations", max_iterations)->capture_default_str();
    app.add_flag("--progress", progress, "Ceres iteration log");
    app.add_flag("--quiet", quiet, "no report on stdout");
    app.add_flag("--print-parameters", print,
                 "print the (--start/--set) parameters as a parameter file and exit");
    app.add_option("--synthesize", synth_file,
                   "write synthetic data from the (--start/--set) parameters to this CSV "
                   "instead of fitting");
    app.add_option("--case", case_list, "synthesize: load cases (comma list or all)")
        ->capture_default_str();
    app.add_option("--state", state_list, "synthesize: active, passive, or both")
        ->capture_default_str();
    app.add_option("--stretch", stretch_spec, "synthesize: START:STOP:COUNT")
        ->capture_default_str();
    app.add_option("--shear", shear_spec, "synthesize: SAF shears (default stretch - 1)");
    app.add_option("--kinematics", kinematics,
                   "synthesize: exact, or paper (UTCTF with F = diag(l, l^-1/2, l^-1/2))")
        ->capture_default_str();
    app.add_option("--noise", noise, "synthesize: Gaussian noise, sd = NOISE x max|P| per curve")
        ->capture_default_str();
    app.add_option("--seed", seed, "synthesize: random seed")->capture_default_str();
    if (!parse_command_line(app, std::move(args)))
      return 0;

    const Model model = parse_model(model_name);
    ParameterSet start(model);
    if (!start_file.empty())
      read_parameter_file(start_file, start);
    for (const std::string& a : assignments)
      start.set_assignment(a);
    start.validate();

    if (print)
    {
      std::printf("%s", start.to_text().c_str());
      return 0;
    }
    if (!synth_file.empty())
      return synthesize_main(start, synth_file, case_list, state_list, stretch_spec,
                             shear_spec, kinematics, noise, seed);

    if (data_files.empty())
      throw InputError("no data: give --data FILE... (or --synthesize FILE)");
    std::vector<DataPoint> data;
    for (const std::string& f : data_files)
    {
      const auto d = read_data_csv(f);
      data.insert(data.end(), d.begin(), d.end());
    }

    FitOptions options;
    options.max_iterations = max_iterations;
    options.progress = progress;
    options.scale_curves = scale_curves;
    std::vector<std::string> free
        = app.count("--free") ? split_list(free_list) : default_free_parameters(model);
    for (const std::string& name : split_list(fix_list))
    {
      (void)start[name]; // unknown: suggestion
      const auto it = std::find(free.begin(), free.end(), name);
      if (it == free.end())
        throw InputError("--fix " + name + ": not a free parameter; free: " + join(free));
      free.erase(it);
    }
    options.free = free;
    for (const std::string& b : bound_specs)
    {
      const auto [name, range] = split_assignment(b, "--bounds", "NAME=LO:HI");
      const auto colon = range.find(':');
      if (colon == std::string::npos)
        throw InputError("--bounds " + b + ": expected NAME=LO:HI");
      options.bounds[name] = {parse_number(range.substr(0, colon), "--bounds " + name + " lower"),
                              parse_number(range.substr(colon + 1), "--bounds " + name + " upper")};
    }
    for (const std::string& w : weight_specs)
    {
      const auto [key, value] = split_assignment(w, "--weight", "CASE[:state]=W");
      options.weights[key] = parse_number(value, "--weight " + key);
    }

    const FitResult result = fit_parameters(start, data, options);

    const std::filesystem::path dir(out);
    std::filesystem::create_directories(dir);
    const std::string report = report_text(result);
    if (!quiet)
      std::printf("%s", report.c_str());
    const auto params = dir / (to_string(model) + ".params");
    write_text(params, result.fitted.to_text());
    write_text(dir / "report.txt", report);
    write_text(dir / "fit.json", report_json(result));
    write_plot_data(dir, result, data);
    std::printf("\nwrote %s (name=value lines: loadcases --set $(cat %s)), report.txt, "
                "fit.json, fit_points.csv, fit_curves.csv in %s\n",
                params.c_str(), params.c_str(), dir.c_str());
    if (!no_plot)
    {
      const std::string image = png.empty() ? (dir / "fit.png").string() : png;
      const std::string title = to_string(model) + " fit, " + std::to_string(data.size())
                                + " points";
      if (run_plot_script("demos/fit/plot_fit.py",
                          {(dir / "fit_points.csv").string(),
                           (dir / "fit_curves.csv").string(), image, title}))
        std::printf("wrote %s\n", image.c_str());
    }
    if (!result.converged)
      throw SolveError("the fit did not converge: " + result.termination);
    if (strict and !result.identifiability.all_determined())
      throw SolveError("--strict: not determined by the data: "
                       + join(result.identifiability.flagged()));
    return 0;
  });
}
