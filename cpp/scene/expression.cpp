#include "scene/expression.h"

#include "common/errors.h"

#include <muParser.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <string_view>

namespace muscle
{

struct Expression::Compiled
{
  mu::Parser parser;
  std::vector<double> values;    ///< the parser's variables
  std::vector<std::size_t> used; ///< indices of the variables the formula uses
};

namespace
{
// muParser's own functions (ln, log2, sum, variadic min and max, ...) are
// replaced by these, so that the list in the messages is complete
const std::pair<const char*, mu::fun_type1> unary_functions[] = {
    {"sin", [](double a) { return std::sin(a); }},
    {"cos", [](double a) { return std::cos(a); }},
    {"tan", [](double a) { return std::tan(a); }},
    {"exp", [](double a) { return std::exp(a); }},
    {"log", [](double a) { return std::log(a); }},
    {"sqrt", [](double a) { return std::sqrt(a); }},
    {"abs", [](double a) { return std::abs(a); }},
    {"tanh", [](double a) { return std::tanh(a); }}};
const std::pair<const char*, mu::fun_type2> binary_functions[] = {
    {"min", [](double a, double b) { return std::min(a, b); }},
    {"max", [](double a, double b) { return std::max(a, b); }}};

std::vector<std::string> function_names()
{
  std::vector<std::string> names;
  for (const auto& [name, _] : unary_functions)
    names.push_back(name);
  for (const auto& [name, _] : binary_functions)
    names.push_back(name);
  return names;
}

constexpr std::size_t max_length = 10000, max_depth = 200;

bool is_name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) or c == '_'; }

[[noreturn]] void fail(const std::string& text, std::size_t i, const std::string& what)
{
  throw InputError("expression '" + text + "': " + what + " at character " + std::to_string(i + 1));
}

/// The text as muParser wants it, after the checks muParser does not make:
/// bounded length and nesting, no ',' outside a function's arguments (muParser
/// would return several values), no lone '=' (it would assign to a variable).
std::string prepare(const std::string& text)
{
  if (text.size() > max_length)
    fail(text, max_length,
         "formula too long (more than " + std::to_string(max_length) + " characters)");
  std::string s = text;
  std::vector<bool> calls; // per open '(': does it hold a function's arguments?
  for (std::size_t i = 0; i < s.size(); ++i)
  {
    if (s[i] == '(')
    {
      // muParser wants a function's '(' right after its name; moving the
      // spaces behind it keeps the other characters' positions for messages
      std::size_t j = i;
      while (j > 0 and std::isspace(static_cast<unsigned char>(s[j - 1])))
        --j;
      std::rotate(s.begin() + j, s.begin() + i, s.begin() + i + 1);
      calls.push_back(j > 0 and is_name_char(s[j - 1]));
      if (calls.size() > max_depth)
        fail(text, i, "nesting too deep");
    }
    else if (s[i] == ')' and !calls.empty())
      calls.pop_back();
    else if (s[i] == ',' and (calls.empty() or !calls.back()))
      fail(text, i, "unexpected ','");
    else if (s[i] == '=')
    {
      const bool after = i > 0 and std::string_view("<>=!").find(s[i - 1]) != s.npos;
      const bool before = i + 1 < s.size() and s[i + 1] == '=';
      if (!after and !before)
        fail(text, i, "unexpected '='");
    }
  }
  return s;
}

/// muParser's error as an InputError naming the position (1-based) and what
/// was expected; an unknown name with the variables and functions allowed.
[[noreturn]] void report(const mu::ParserError& e, const std::string& text,
                         const std::vector<std::string>& variables)
{
  const std::string& token = e.GetToken();
  std::size_t at = std::min<std::size_t>(e.GetPos() < 0 ? text.size() : e.GetPos(), text.size());
  // muParser places a doubled sign's position after it, other tokens' at their start
  if (at >= token.size() and text.compare(at, token.size(), token) != 0
      and text.compare(at - token.size(), token.size(), token) == 0)
    at -= token.size();
  switch (e.GetCode())
  {
  case mu::ecUNEXPECTED_EOF:
  case mu::ecEMPTY_EXPRESSION:
    fail(text, text.size(), "unexpected end, expected a number, variable or '('");
  case mu::ecMISSING_PARENS:
    fail(text, text.size(), "expected ')'");
  case mu::ecTOO_FEW_PARAMS:
  case mu::ecTOO_MANY_PARAMS:
    fail(text, at,
         token + (token == "min" or token == "max" ? " takes 2 arguments" : " takes 1 argument"));
  case mu::ecUNASSIGNABLE_TOKEN:
    if (token.empty())
      break;
    if (std::isdigit(static_cast<unsigned char>(token[0])) or token[0] == '.')
      fail(text, at, "malformed number");
    if (is_name_char(token[0]))
    {
      const std::string name(token.begin(),
                             std::find_if_not(token.begin(), token.end(), is_name_char));
      const std::vector<std::string> functions = function_names();
      if (std::find(functions.begin(), functions.end(), name) != functions.end())
        fail(text, at + name.size(), "expected '(' after " + name);
      std::vector<std::string> known = variables;
      known.insert(known.end(), functions.begin(), functions.end());
      throw InputError("expression '" + text + "': unknown name '" + name + "'; variables: "
                       + join(variables) + ", functions: " + join(functions, " ")
                       + did_you_mean(name, known));
    }
    fail(text, at, "unexpected '" + token.substr(0, 1) + "'");
  default:
    break;
  }
  fail(text, at, token.empty() ? e.GetMsg() : "unexpected '" + token + "'");
}
} // namespace

Expression::Expression(const std::string& text, const std::vector<std::string>& variables)
    : _text(text), _variables(variables), _compiled(std::make_unique<Compiled>())
{
  mu::Parser& p = _compiled->parser;
  // the optimizer would rewrite (z - 50)/20 as z*0.05 - 2.5 and x^3 as x*x*x:
  // not the arithmetic written (last bits), for a small saving
  p.EnableOptimizer(false);
  p.ClearFun();
  p.ClearConst();
  for (const auto& [name, f] : unary_functions)
    p.DefineFun(name, f);
  for (const auto& [name, f] : binary_functions)
    p.DefineFun(name, f);
  p.DefineConst("pi", std::numbers::pi);
  _compiled->values.resize(variables.size());
  for (std::size_t k = 0; k < variables.size(); ++k)
    p.DefineVar(variables[k], &_compiled->values[k]);
  try
  {
    p.SetExpr(prepare(text));
    p.Eval(); // compiles, or throws
    // only now: before, GetUsedVar would take unknown names for variables
    for (const auto& [name, _] : p.GetUsedVar())
      _compiled->used.push_back(std::find(variables.begin(), variables.end(), name)
                                - variables.begin());
  }
  catch (const mu::ParserError& e)
  {
    report(e, text, variables);
  }
}

Expression::~Expression() = default;
// muParser's own copy would still read the original's variables
Expression::Expression(const Expression& other) : Expression(other._text, other._variables) {}
Expression& Expression::operator=(const Expression& other) { return *this = Expression(other); }
Expression::Expression(Expression&&) noexcept = default;
Expression& Expression::operator=(Expression&&) noexcept = default;

double Expression::operator()(const double* values) const
{
  for (std::size_t k : _compiled->used)
    _compiled->values[k] = values[k];
  return _compiled->parser.Eval();
}

bool Expression::uses(const std::string& variable) const
{
  for (std::size_t k : _compiled->used)
    if (_variables[k] == variable)
      return true;
  return false;
}

} // namespace muscle
