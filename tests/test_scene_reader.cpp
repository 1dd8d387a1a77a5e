// Scene reader: expressions, time functions and point data against direct
// evaluation, and a fuzz test -- random mutations of every demo scene either
// read or stop with an InputError, never anything else.
#include <common/errors.h>
#include <scene/expression.h>
#include <scene/point_data.h>
#include <scene/scene.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <random>
#include <regex>
#include <sstream>

using namespace muscle;

namespace
{
const std::string scenes = std::string(MUSCLE_SOURCE_DIR) + "/demos/scenes";

std::string read_text(const std::string& path)
{
  std::stringstream s;
  s << std::ifstream(path).rdbuf();
  return s.str();
}

std::vector<std::string> demo_scenes()
{
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(scenes))
    if (entry.path().extension() == ".yaml")
      files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}
} // namespace

TEST(SceneDefaults, PartWithoutMaterialTakesTheMuscleDefault)
{
  // the law declared DEFAULT_FOR "muscle" in its file (combi.py), no name in C++
  const Part part;
  EXPECT_EQ(part.parameters.model(), default_model("muscle"));
  EXPECT_EQ(part.parameters.model().name(), "combi");
}

TEST(Expression, AgreesWithDirectEvaluation)
{
  const std::vector<std::string> vars = {"x", "y", "z", "t"};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2, 2);
  const Expression e1("0.5 + 0.5*exp(-((z - 50)/20)^2) * min(1, t/0.05)", vars);
  const Expression e2("-x^2 + 2^3^0.5 - sqrt(abs(y)) / (1 + tanh(z)) + max(x, y) * (t >= 0)", vars);
  const Expression e3("sin(pi*x)*cos(y) - log(1 + x*x) + (x < y) - (x > y) + (x <= x) + (y >= 1)", vars);
  for (int k = 0; k < 100; ++k)
  {
    const double v[4] = {u(rng), u(rng), 50 + 20 * u(rng), std::abs(u(rng)) / 10};
    const double x = v[0], y = v[1], z = v[2], t = v[3];
    EXPECT_DOUBLE_EQ(e1(v), 0.5 + 0.5 * std::exp(-std::pow((z - 50) / 20, 2)) * std::min(1.0, t / 0.05));
    EXPECT_DOUBLE_EQ(e2(v), -x * x + std::pow(2.0, std::pow(3.0, 0.5))
                                - std::sqrt(std::abs(y)) / (1 + std::tanh(z)) + std::max(x, y));
    EXPECT_DOUBLE_EQ(e3(v), std::sin(M_PI * x) * std::cos(y) - std::log(1 + x * x) + (x < y)
                                - (x > y) + 1 + (y >= 1));
  }
  EXPECT_TRUE(e1.uses("t"));
  EXPECT_FALSE(e1.uses("x"));
}

TEST(Expression, ReportsMistakes)
{
  for (const char* bad : {"", "1 +", "(x", "x)", "exp x", "min(x)", "2..3", "foo(x)", "w", "x $ y",
                          "max(x,", "1e"})
    EXPECT_THROW(Expression(bad, {"x", "y"}), InputError) << bad;
  // nesting and length are bounded, not a stack overflow
  EXPECT_THROW(Expression(std::string(100000, '(') + "x", {"x"}), InputError);
  EXPECT_THROW(Expression(std::string(100000, '-') + "1", {"x"}), InputError);
  EXPECT_THROW(Expression("2" + std::string(100000, '^') + "1", {"x"}), InputError);
  std::string sum = "1";
  for (int i = 0; i < 100000; ++i)
    sum += "+1";
  EXPECT_THROW(Expression(sum, {"x"}), InputError);
  EXPECT_EQ(Expression("1+1+1", {"x"})(nullptr), 3);
}

TEST(TimeFunction, RampAndTable)
{
  TimeFunction ramp;
  ramp.kind = TimeFunction::Kind::ramp;
  ramp.start = 0.1;
  ramp.duration = 0.2;
  ramp.value = 4;
  EXPECT_EQ(ramp(0.0), 0);
  EXPECT_DOUBLE_EQ(ramp(0.2), 2);
  EXPECT_EQ(ramp(1.0), 4);
  TimeFunction table;
  table.kind = TimeFunction::Kind::table;
  table.table = {{0, 1}, {1, 3}, {2, 0}};
  EXPECT_EQ(table(-1), 1);
  EXPECT_DOUBLE_EQ(table(0.25), 1.5);
  EXPECT_DOUBLE_EQ(table(1.5), 1.5);
  EXPECT_EQ(table(5), 0);
}

TEST(PointData, NearestPointEqualsBruteForce)
{
  const std::string path = std::filesystem::temp_directory_path() / "muscle_point_data.csv";
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::array<double, 3>> points;
  {
    std::ofstream f(path);
    f << "# random points\nx,y,z,0,0.5\n";
    for (int i = 0; i < 3000; ++i)
    {
      points.push_back({10 * u(rng), 10 * u(rng), 100 * u(rng)});
      f << points.back()[0] << "," << points.back()[1] << "," << points.back()[2] << "," << i << ","
        << 2 * i << "\n";
    }
  }
  const PointData data(path, 0);
  ASSERT_TRUE(data.timed());
  for (int k = 0; k < 2000; ++k)
  {
    const std::array<double, 3> x = {12 * u(rng) - 1, 12 * u(rng) - 1, 110 * u(rng) - 5};
    std::size_t best = 0;
    double best_d = 1e300;
    for (std::size_t i = 0; i < points.size(); ++i)
    {
      double d = 0;
      for (int j = 0; j < 3; ++j)
        d += (points[i][j] - x[j]) * (points[i][j] - x[j]);
      if (d < best_d)
        best_d = d, best = i;
    }
    const std::size_t row = data.nearest(x);
    double d = 0;
    for (int j = 0; j < 3; ++j)
      d += (points[row][j] - x[j]) * (points[row][j] - x[j]);
    ASSERT_EQ(d, best_d) << "query " << k;
    EXPECT_DOUBLE_EQ(data.value_at(row, 0.25), 1.5 * row);
  }
  std::filesystem::remove(path);
}

TEST(PointData, MalformedRowsNameFileAndLine)
{
  const std::string path = std::filesystem::temp_directory_path() / "muscle_bad_points.csv";
  std::ofstream(path) << "x,y,z,scale\n1,2,3,0.5\n1,2,three,0.5\n";
  try
  {
    PointData data(path, 1);
    FAIL() << "no error";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(path + ":3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'three'"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

TEST(SceneReader, DemoScenesRead)
{
  for (const std::string& file : demo_scenes())
  {
    const Scene s = read_scene(file);
    EXPECT_FALSE(s.parts.empty()) << file;
    EXPECT_FALSE(s.boundary.empty()) << file;
  }
}

/// Random edits of valid scenes: character deletions, insertions and
/// substitutions from YAML's syntax characters, line swaps and duplications,
/// number changes.  Every outcome must be a scene or an InputError.
TEST(SceneReader, FuzzedScenesNeverCrash)
{
  std::mt19937 rng(2026);
  const std::string alphabet = ":{}[],-#&*!|>'\"%@` \t\n0123456789.eE+-abcxyz_";
  int read = 0, rejected = 0;
  for (const std::string& file : demo_scenes())
  {
    const std::string original = read_text(file);
    for (int trial = 0; trial < 700; ++trial)
    {
      std::string text = original;
      const int edits = 1 + rng() % 4;
      for (int e = 0; e < edits; ++e)
      {
        const std::size_t at = text.empty() ? 0 : rng() % text.size();
        switch (rng() % 6)
        {
        case 0:
          text.erase(at, 1 + rng() % 8);
          break;
        case 1:
          text.insert(at, 1, alphabet[rng() % alphabet.size()]);
          break;
        case 2:
          if (!text.empty())
            text[at] = alphabet[rng() % alphabet.size()];
          break;
        case 3: // duplicate a line
        {
          const std::size_t begin = text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
          const std::size_t end = text.find('\n', at);
          text.insert(begin, text.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1));
          break;
        }
        case 4: // a number becomes something extreme
        {
          const std::size_t d = text.find_first_of("0123456789", at);
          if (d != std::string::npos)
          {
            const char* values[] = {"-1", "0", "1e308", "nan", "inf", "-0", "1e-320", "99999999999"};
            text.replace(d, 1, values[rng() % 8]);
          }
          break;
        }
        default: // swap two lines
        {
          std::vector<std::string> lines;
          std::stringstream s(text);
          for (std::string l; std::getline(s, l);)
            lines.push_back(l);
          if (lines.size() > 2)
            std::swap(lines[rng() % lines.size()], lines[rng() % lines.size()]);
          text.clear();
          for (const auto& l : lines)
            text += l + "\n";
        }
        }
      }
      try
      {
        parse_scene(text, file, scenes);
        ++read;
      }
      catch (const InputError& e)
      {
        ++rejected;
        EXPECT_EQ(std::string(e.what()).rfind(file, 0), 0u) << "message without the file: " << e.what();
      }
      catch (const std::exception& e)
      {
        ADD_FAILURE() << "not an InputError: " << e.what() << "\n--- scene ---\n" << text;
      }
    }
  }
  std::printf("fuzz: %d mutated scenes read, %d rejected with a message\n", read, rejected);
  EXPECT_GT(rejected, 1000);
}

// --set KEY=VALUE: the value lands where the dotted path says, a new key of a
// mapping is checked like one written in the file, and every mistake names the
// --set it came from.
TEST(SceneOverrides, ReplaceAddAndLocate)
{
  const std::string file = scenes + "/block_graded.yaml";
  const std::string text = read_text(file);
  const Scene plain = parse_scene(text, file, scenes);
  const Scene set = parse_scene(text, file, scenes,
                                {"time.step=0.02", "parts[0].material.parameters.mu=20",
                                 "mesh.set.refinement=2", "element.fbar=true",
                                 "element.degree=1", "solver.linear=gmres-gamg"});
  EXPECT_DOUBLE_EQ(plain.time.dt, 0.01);
  EXPECT_DOUBLE_EQ(set.time.dt, 0.02);
  EXPECT_DOUBLE_EQ(plain.parts[0].parameters["mu"], 10.0);
  EXPECT_DOUBLE_EQ(set.parts[0].parameters["mu"], 20.0);
  EXPECT_TRUE(set.parts[0].parameters.explicitly_set("mu"));
  EXPECT_DOUBLE_EQ(set.mesh.numbers.at("refinement"), 2.0);
  EXPECT_TRUE(set.mesh.fbar and !plain.mesh.fbar);
  EXPECT_EQ(set.newton.linear_solver, "gmres-gamg"); // a section the file does not have
  EXPECT_EQ(set.overrides.size(), 6u);
  EXPECT_NE(set.physics, plain.physics); // a checkpoint of one does not resume the other

  auto message = [&](const std::string& assignment)
  {
    try
    {
      parse_scene(text, file, scenes, {assignment});
    }
    catch (const InputError& e)
    {
      return std::string(e.what());
    }
    return std::string("(read without error)");
  };
  for (const auto& [assignment, expected] : std::vector<std::pair<std::string, std::string>>{
           {"time.stpe=1", "did you mean 'step'"},
           {"parts[1].name=x", "parts[1] does not exist"},
           {"parts.name=x", "is a list: name an item, parts[N].name"},
           {"time[0]=1", "'time' is not a list"},
           {"time.step=", "no value"},
           {"=3", "no key"},
           {"time..step=3", "empty name"},
           {"parts[x].name=a", "not a list index"},
           {"parts[0].material.parameters.kappa=0", "must be > 0"},
           {"element.degree=3", "integer from 1 to 2"}})
  {
    const std::string m = message(assignment);
    EXPECT_EQ(m.rfind("--set " + assignment, 0), 0u) << assignment << ": " << m;
    EXPECT_NE(m.find(expected), std::string::npos) << assignment << ": " << m;
  }
}

// One reader for parameter files: the scene reads the CRLF file `fit` reads.
TEST(SceneReader, ParameterFileWithCrlfLineEnds)
{
  const auto dir = std::filesystem::temp_directory_path() / "muscle_crlf_params";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "ble.params") << "# fitted\r\nmu=12.5\r\n\r\nkappa=2000\r\n";
  const std::string text = read_text(scenes + "/block_graded.yaml");
  const std::string with_file = std::regex_replace(
      text, std::regex("material: \\{model: ble\\}"),
      "material: {model: ble, parameter_file: " + (dir / "ble.params").string() + "}");
  ASSERT_NE(with_file, text);
  const Scene scene = parse_scene(with_file, "crlf.yaml", scenes);
  EXPECT_DOUBLE_EQ(scene.parts[0].parameters["mu"], 12.5);
  EXPECT_DOUBLE_EQ(scene.parts[0].parameters["kappa"], 2000.0);
  std::filesystem::remove_all(dir);
}
