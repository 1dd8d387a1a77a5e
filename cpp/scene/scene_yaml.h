#pragma once

// The scene's YAML tree with every value's place in the file (or the
// `--set` that gave it), so that each check reports where the mistake is.
#include "scene/scene.h"

#include <map>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace muscle::scene_input
{

/// Where a scene's values come from: the file, and the command line's
/// `--set KEY=VALUE` for the keys it replaced.
struct Source
{
  std::string file;
  std::map<std::string, std::string> overrides; ///< dotted key -> "--set KEY=VALUE"
};

/// Replace (or add) the value at a dotted path of the scene's YAML tree, and
/// note in `source` that the key now comes from the command line.
void apply_override(YAML::Node& root, const std::string& assignment, Source& source);

/// A YAML node and where it is: every accessor checks and reports in place.
class Entry
{
public:
  Entry(YAML::Node node, std::string key, const Source& source, int parent_line);

  bool defined() const { return _node.IsDefined() and !_node.IsNull(); }
  bool is_map() const { return _node.IsMap(); }
  bool is_sequence() const { return _node.IsSequence(); }
  bool is_scalar() const { return _node.IsScalar(); }
  const std::string& key() const { return _key; }

  SceneLocation where() const { return {_origin ? *_origin : _source.file, _line, _key}; }

  [[noreturn]] void fail(const std::string& what) const;

  std::string shown() const;

  /// Child of a mapping; undefined (not an error) if this is no mapping or
  /// lacks the key, so that optional keys read with a fallback.
  Entry operator[](const std::string& name) const;

  Entry at(std::size_t i) const;
  std::size_t size() const { return _node.size(); }

  /// A mapping whose keys are all in `allowed`.
  const Entry& require_map(const std::vector<std::string>& allowed) const;

  std::vector<std::string> keys() const;

  /// The one key present out of alternatives (e.g. clamp | displacement).
  std::string one_of(const std::vector<std::string>& alternatives) const;

  std::string text() const;
  std::string text(const std::string& fallback) const
  {
    return defined() ? text() : fallback;
  }

  std::string choice(const std::vector<std::string>& allowed) const;

  double number() const;
  double number(double fallback) const { return defined() ? number() : fallback; }

  double positive(double fallback) const;

  int integer(int fallback, int lower, int upper) const;

  bool flag(bool fallback) const;

  Entry required(const std::string& name) const;

private:
  YAML::Node _node;
  std::string _key;
  const Source& _source;
  const std::string* _origin = nullptr; ///< the --set that gave the value, if one did
  int _line;
};

} // namespace muscle::scene_input
