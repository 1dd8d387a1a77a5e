// Located YAML: each accessor of an Entry checks the value it returns and
// reports a mistake as "FILE:LINE: KEY: what is wrong; what is allowed".
#include "scene/scene_yaml.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>

namespace muscle
{

std::string SceneLocation::text() const
{
  std::string s = file;
  if (line > 0)
    (s += ':') += std::to_string(line);
  if (!key.empty())
    s += ": " + key;
  return s;
}

namespace scene_input
{

Entry::Entry(YAML::Node node, std::string key, const Source& source, int parent_line)
    : _node(node), _key(std::move(key)), _source(source),
      _line(node.IsDefined() and node.Mark().line >= 0 ? node.Mark().line + 1 : parent_line)
{
  if (auto it = source.overrides.find(_key); it != source.overrides.end())
  {
    _origin = &it->second;
    _line = 0;
  }
}

void Entry::fail(const std::string& what) const
{
  throw InputError(where().text() + ": " + what);
}

std::string Entry::shown() const
{
  if (_node.IsScalar())
    return "'" + _node.Scalar() + "'";
  if (_node.IsSequence())
    return "a list";
  if (_node.IsMap())
    return "a mapping";
  return "nothing";
}

Entry Entry::operator[](const std::string& name) const
{
  return Entry(_node.IsMap() ? _node[name] : YAML::Node(YAML::NodeType::Undefined),
               _key.empty() ? name : _key + "." + name, _source, _line);
}

Entry Entry::at(std::size_t i) const
{
  return Entry(_node[i], _key + "[" + std::to_string(i) + "]", _source, _line);
}

const Entry& Entry::require_map(const std::vector<std::string>& allowed) const
{
  if (!_node.IsMap())
    fail("expected a mapping with keys " + join(allowed) + ", found " + shown());
  for (auto it = _node.begin(); it != _node.end(); ++it)
  {
    if (!it->first.IsScalar())
      fail("keys must be names");
    const std::string k = it->first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), k) == allowed.end())
    {
      Entry child(it->second, _key.empty() ? k : _key + "." + k, _source,
                  it->first.Mark().line + 1);
      child.fail("unknown key '" + k + "'" + did_you_mean(k, allowed)
                 + "; allowed here: " + join(allowed));
    }
  }
  return *this;
}

std::vector<std::string> Entry::keys() const
{
  std::vector<std::string> k;
  if (_node.IsMap())
    for (auto it = _node.begin(); it != _node.end(); ++it)
      k.push_back(it->first.Scalar());
  return k;
}

std::string Entry::one_of(const std::vector<std::string>& alternatives) const
{
  std::string found;
  for (const std::string& k : keys())
    if (std::find(alternatives.begin(), alternatives.end(), k) != alternatives.end())
    {
      if (!found.empty())
        fail("give only one of " + join(alternatives) + " (found '" + found + "' and '" + k
             + "')");
      found = k;
    }
  if (found.empty())
    fail("expected one of " + join(alternatives));
  return found;
}

std::string Entry::text() const
{
  if (!_node.IsScalar())
    fail("expected a text value, found " + shown());
  return _node.Scalar();
}

std::string Entry::choice(const std::vector<std::string>& allowed) const
{
  const std::string v = text();
  if (std::find(allowed.begin(), allowed.end(), v) == allowed.end())
    fail("'" + v + "' is not allowed; allowed: " + join(allowed) + did_you_mean(v, allowed));
  return v;
}

double Entry::number() const
{
  if (!_node.IsScalar())
    fail("expected a number, found " + shown());
  const std::string& s = _node.Scalar();
  if (!parse_real(s, false))
    fail("'" + s + "' is not a number");
  const auto v = parse_real(s);
  if (!v)
    fail("'" + s + "' is not a finite number");
  return *v;
}

double Entry::positive(double fallback) const
{
  const double v = number(fallback);
  if (!(v > 0))
    fail("'" + text() + "' must be > 0");
  return v;
}

int Entry::integer(int fallback, int lower, int upper) const
{
  if (!defined())
    return fallback;
  const double v = number();
  if (v == std::floor(v) and v >= lower and v <= upper)
    return static_cast<int>(v);
  const std::string given = text();
  fail("'" + given + "' must be an integer from " + std::to_string(lower) + " to "
       + std::to_string(upper));
}

bool Entry::flag(bool fallback) const
{
  if (!defined())
    return fallback;
  const std::string v = text();
  if (v == "true" or v == "yes" or v == "on")
    return true;
  if (v == "false" or v == "no" or v == "off")
    return false;
  fail("'" + v + "' is not allowed; allowed: true, false");
}

Entry Entry::required(const std::string& name) const
{
  Entry e = (*this)[name];
  if (!e.defined())
    fail("missing key '" + name + "'");
  return e;
}

} // namespace scene_input
} // namespace muscle
