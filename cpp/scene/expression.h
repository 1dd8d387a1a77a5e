#pragma once

#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// A scalar formula of named variables, read once and evaluated many times,
/// e.g. "0.5 + 0.5*exp(-((z - 50)/20)^2) * min(1, t/0.05)".
///
/// Grammar: numbers, variables, + - * / ^ (right-associative), unary minus,
/// parentheses, comparisons < > <= >= (1 or 0), functions sin cos tan exp log
/// sqrt abs tanh min max, the constant pi.
class Expression
{
public:
  /// Throws InputError naming the position and what was expected; unknown
  /// names are reported with the allowed variables.
  Expression(const std::string& text, const std::vector<std::string>& variables);
  ~Expression();
  Expression(const Expression&);
  Expression& operator=(const Expression&);

  /// `values` in the order of the constructor's `variables`.
  double operator()(const double* values) const;

  const std::string& text() const { return _text; }
  /// Does the formula use this variable?
  bool uses(const std::string& variable) const;

  struct Node;

private:
  std::string _text;
  std::vector<std::string> _variables;
  std::shared_ptr<const Node> _root;
};

} // namespace muscle
