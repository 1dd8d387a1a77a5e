#include "fit/data.h"

#include <common/errors.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

namespace muscle::fit
{
namespace
{
std::string trim(const std::string& s)
{
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos)
    return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& line)
{
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ','))
    out.push_back(trim(field));
  if (!line.empty() and line.back() == ',')
    out.push_back("");
  return out;
}

const std::vector<std::string>& required_columns()
{
  static const std::vector<std::string> c = {"case", "state", "stretch", "stress"};
  return c;
}
} // namespace

std::string to_string(const CurveKey& key)
{
  return muscle::to_string(key.load_case) + " " + muscle::to_string(key.state);
}

MuscleState parse_state_name(const std::string& name)
{
  if (name == "active")
    return MuscleState::active;
  if (name == "passive")
    return MuscleState::passive;
  throw InputError("unknown muscle state '" + name + "'"
                   + did_you_mean(name, {"active", "passive"})
                   + "; allowed: active, passive");
}

std::vector<DataPoint> read_data_csv(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw InputError("cannot read data file " + path);
  std::vector<DataPoint> points;
  std::map<std::string, std::size_t> column; // name -> index
  std::size_t fields = 0;
  std::string line;
  int number = 0;
  auto where = [&]() { return path + ":" + std::to_string(number) + ": "; };
  while (std::getline(in, line))
  {
    ++number;
    const std::string t = trim(line);
    if (t.empty() or t[0] == '#')
      continue;
    const std::vector<std::string> f = split(t);
    if (column.empty())
    {
      for (std::size_t i = 0; i < f.size(); ++i)
        column[f[i]] = i;
      for (const std::string& c : required_columns())
        if (!column.count(c))
        {
          std::vector<std::string> found(f.begin(), f.end());
          std::string hint;
          for (const std::string& name : found)
            if (!did_you_mean(name, {c}).empty())
              hint = " (is '" + name + "' meant to be '" + c + "'?)";
          throw InputError(where() + "the header lacks the column '" + c + "'" + hint
                           + "; expected the header case,state,stretch,stress, found '"
                           + t + "'");
        }
      fields = f.size();
      continue;
    }
    if (f.size() != fields)
      throw InputError(where() + "expected " + std::to_string(fields)
                       + " comma-separated fields as in the header, found "
                       + std::to_string(f.size()) + " in '" + t + "'");
    DataPoint p;
    p.file = path;
    p.line = number;
    try
    {
      p.load_case = parse_load_case(f[column["case"]]);
    }
    catch (const InputError& e)
    {
      throw InputError(where() + "column 'case': " + e.what());
    }
    try
    {
      p.state = parse_state_name(f[column["state"]]);
    }
    catch (const InputError& e)
    {
      throw InputError(where() + "column 'state': " + e.what());
    }
    for (const std::string name : {"stretch", "stress"})
    {
      const std::string& text = f[column[name]];
      const auto value = parse_real(text);
      if (!value)
        throw InputError(where() + "column '" + name + "': '" + text
                         + "' is not a finite number");
      (name == std::string("stretch") ? p.control : p.stress) = *value;
    }
    if (p.load_case != LoadCase::SAF and !(p.control > 0))
      throw InputError(where() + "column 'stretch': " + f[column["stretch"]]
                       + " is not allowed for " + muscle::to_string(p.load_case)
                       + ": stretches must be positive (only SAF takes a shear, "
                         "which may be any number)");
    points.push_back(p);
  }
  if (column.empty())
    throw InputError(path + ": empty file; expected the header case,state,stretch,stress");
  if (points.empty())
    throw InputError(path + ": no data rows after the header");
  return points;
}

void write_data_csv(const std::string& path, const std::vector<DataPoint>& points)
{
  std::ofstream out(path);
  if (!out)
    throw InputError("cannot write " + path);
  out << "case,state,stretch,stress\n" << std::setprecision(12);
  for (const DataPoint& p : points)
    out << muscle::to_string(p.load_case) << "," << muscle::to_string(p.state) << ","
        << p.control << "," << p.stress << "\n";
}

} // namespace muscle::fit
