#pragma once

#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// A scalar formula of named variables, read once and evaluated many times,
/// e.g. "0.5 + 0.5*exp(-((z - 50)/20)^2) * min(1, t/0.05)"; muParser compiles it.
///
/// Grammar: numbers, variables, + - * / ^ (right-associative), one unary sign
/// (2*-x, not --x), parentheses, comparisons < > <= >= (1 or 0), functions sin
/// cos tan exp log (natural) sqrt abs tanh min max, the constant pi; and
/// muParser's == != && || and c ? a : b.
class Expression
{
public:
  /// Throws InputError naming the position and what was expected; unknown
  /// names are reported with the allowed variables.
  Expression(const std::string& text, const std::vector<std::string>& variables);
  ~Expression();
  Expression(const Expression&);
  Expression& operator=(const Expression&);
  Expression(Expression&&) noexcept;
  Expression& operator=(Expression&&) noexcept;

  /// `values` in the order of the constructor's `variables` (only the used
  /// ones are read).  muParser evaluates in place: one object must not be
  /// called from two threads at once, copies are independent.
  double operator()(const double* values) const;

  const std::string& text() const { return _text; }
  /// Does the formula use this variable?
  bool uses(const std::string& variable) const;

private:
  struct Compiled;
  std::string _text;
  std::vector<std::string> _variables;
  std::unique_ptr<Compiled> _compiled;
};

} // namespace muscle
