// Load-case demo: stress-stretch responses of the four muscle models in the six
// load cases of the paper, three ways side by side:
//
//   P_exact  homogeneous, fully incompressible response from the model's stress
//            (pressure from the traction-free direction; UTCTF also solves for
//            the unequal lateral stretches),
//   P_paper  the closed forms of the paper's appendix table (with ERRATA.md),
//            where the paper gives one,
//   P_fe     one nearly incompressible hexahedron under the Dirichlet
//            conditions of the paper's Table constraints_cube.
//
//   loadcases --model ble --case UTCAF --state active --stretch 0.7:1.3:13
//             [--set NAME=VALUE ...] [--csv FILE] [--png FILE]
//
// "active" is the tetanic level: time factor 1 (for WKM/GIANT, P_opt is the
// twitch train's tetanic level unless set with --set P_opt=...).
#include <common/application.h>
#include <common/command_line.h>
#include <common/errors.h>
#include <io/plotting.h>
#include <loadcases/curve.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

using namespace muscle;

namespace
{
template <typename T, typename Parse>
std::vector<T> parse_list(const std::string& text, const std::vector<T>& all, Parse parse)
{
  if (text == "all")
    return all;
  std::vector<T> out;
  std::size_t start = 0;
  while (start <= text.size())
  {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    out.push_back(parse(text.substr(start, comma - start)));
    start = comma + 1;
  }
  return out;
}

/// --set NAME=VALUE applies to every selected model that has NAME; a name no
/// selected model knows is an error.
std::vector<ParameterSet> parameter_sets(const std::vector<Model>& models,
                                         const std::vector<std::string>& assignments)
{
  std::vector<ParameterSet> sets;
  for (const Model& m : models)
    sets.emplace_back(m);
  for (const std::string& a : assignments)
  {
    const std::string name = a.substr(0, a.find('='));
    bool used = false;
    for (ParameterSet& p : sets)
      if (models.size() == 1 or p.has(name))
      {
        p.set_assignment(a);
        used = true;
      }
    if (!used)
      sets.front().set_assignment(a); // throws: unknown parameter, with the list
  }
  for (const ParameterSet& p : sets)
    p.validate();
  return sets;
}

void print_table(const std::string& title, LoadCase c, const std::vector<CurveRow>& rows)
{
  std::printf("\n%s\n%10s %12s %12s %12s\n", title.c_str(),
              c == LoadCase::SAF ? "shear" : "stretch", "P_exact", "P_paper", "P_fe");
  for (const CurveRow& r : rows)
  {
    std::printf("%10.4f %12.5f ", r.control, r.exact);
    r.paper ? std::printf("%12.5f ", *r.paper) : std::printf("%12s ", "-");
    r.fe ? std::printf("%12.5f\n", *r.fe) : std::printf("%12s\n", "-");
  }
}
} // namespace

int main(int argc, char** argv)
{
  return run_application(argc, argv, [](std::vector<std::string> args) {
    CLI::App app{"Stress-stretch responses of the muscle models in the paper's six "
                 "load cases: exact, paper closed form, single-element FE.\n"
                 "PETSc options (-snes_monitor, -ksp_type ...) are passed through."};
    std::string model_list = "all", case_list = "all", state_list = "both";
    std::string stretch_spec = "0.7:1.3:13", shear_spec, csv, png, out = "loadcases";
    std::vector<std::string> assignments;
    bool no_fe = false, quiet = false;
    CubeOptions fe;
    std::vector<std::string> laws, paper;
    for (const Model& m : all_models())
      laws.push_back(m.name());
    for (const Model& m : paper_models())
      paper.push_back(m.name());
    app.add_option("--model", model_list,
                   "a law (" + join(laws) + "), a comma list, or all (the paper's: " + join(paper)
                       + ")")
        ->capture_default_str();
    app.add_option("--case", case_list,
                   "UTCAF, UTCTF, SAF, PSAF, PSTF, PSTIF, a comma list, or all")
        ->capture_default_str();
    app.add_option("--state", state_list, "active, passive, or both")->capture_default_str();
    app.add_option("--stretch", stretch_spec,
                   "START:STOP:COUNT; for SAF alone the values are shears")
        ->capture_default_str();
    app.add_option("--shear", shear_spec,
                   "START:STOP:COUNT for SAF when several cases run (default: stretch - 1)");
    app.add_option("--set", assignments, "NAME=VALUE: override a material parameter")
        ->take_all();
    app.add_option("--csv", csv, "CSV file (one model, case and state only)");
    app.add_option("--png", png, "PNG grid of the curves (default: in --out)");
    app.add_option("--out", out, "directory for CSV/PNG files")->capture_default_str();
    app.add_flag("--no-fe", no_fe, "skip the finite-element response");
    app.add_option("--cells", fe.cells_per_side, "FE cells per cube side")->capture_default_str();
    app.add_option("--degree", fe.discretisation.degree, "FE displacement degree (1 or 2)")
        ->capture_default_str();
    app.add_flag("--quiet", quiet, "no tables on stdout");
    if (!parse_command_line(app, std::move(args)))
      return 0;

    const auto models = parse_list<Model>(model_list, paper_models(), parse_model);
    const auto cases = parse_list<LoadCase>(case_list, all_load_cases(), parse_load_case);
    const auto states = state_list == "both"
                            ? std::vector<MuscleState>{MuscleState::active, MuscleState::passive}
                            : std::vector<MuscleState>{parse_state(state_list)};
    const std::vector<ParameterSet> sets = parameter_sets(models, assignments);
    const std::vector<double> stretches = parse_range(stretch_spec, "--stretch");
    std::vector<double> shears;
    if (!shear_spec.empty())
      shears = parse_range(shear_spec, "--shear");
    else if (cases.size() == 1)
      shears = stretches;
    else
      for (double s : stretches)
        shears.push_back(s - 1);

    const std::size_t combinations = sets.size() * cases.size() * states.size();
    if (!csv.empty() and combinations != 1)
      throw InputError("--csv needs exactly one model, case and state (this run has "
                       + std::to_string(combinations) + "); use --out DIR instead");
    std::filesystem::create_directories(out);

    // One manifest per state for the plot: which CSV holds which curve.
    std::map<MuscleState, nlohmann::json> manifests;
    for (MuscleState state : states)
      for (const ParameterSet& p : sets)
        for (LoadCase c : cases)
        {
          const auto& controls = c == LoadCase::SAF ? shears : stretches;
          const auto rows = load_case_curve(p, state, c, controls,
                                            no_fe ? std::nullopt : std::optional(fe));
          const std::string file
              = !csv.empty() ? csv
                             : out + "/" + to_string(p.model()) + "_" + to_string(state)
                                   + "_" + to_string(c) + ".csv";
          if (is_root())
            write_curve_csv(file, rows);
          for (const CurveRow& r : rows)
            if (!r.fe_message.empty() and is_root())
              std::fprintf(stderr, "warning: %s %s %s at %g: no P_fe: %s\n",
                           to_string(p.model()).c_str(), to_string(state).c_str(),
                           to_string(c).c_str(), r.control, r.fe_message.c_str());
          if (!quiet and is_root())
            print_table(to_string(p.model()) + " " + to_string(state) + " " + to_string(c)
                            + " [kPa]  -> " + file,
                        c, rows);
          manifests[state].push_back(
              {{"model", to_string(p.model())}, {"case", to_string(c)}, {"csv", file}});
        }

    for (auto& [state, manifest] : manifests)
    {
      std::string image = png;
      if (image.empty())
        image = !csv.empty() ? std::filesystem::path(csv).replace_extension(".png").string()
                             : out + "/loadcases_" + to_string(state) + ".png";
      else if (manifests.size() > 1)
        image = std::filesystem::path(png).replace_extension("").string() + "_"
                + to_string(state) + ".png";
      const std::string manifest_file = image + ".json";
      if (is_root())
        std::ofstream(manifest_file) << nlohmann::json{{"state", to_string(state)},
                                                       {"curves", manifest}}.dump(1);
      run_plot_script("demos/loadcases/plot_loadcases.py", {manifest_file, image});
      if (!quiet and is_root())
        std::printf("\nwrote %s\n", image.c_str());
    }
    return 0;
  });
}
