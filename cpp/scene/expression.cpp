#include "expression.h"

#include "../common/errors.h"

#include <cctype>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>

namespace muscle
{

struct Expression::Node
{
  enum Kind
  {
    number,
    variable,
    unary,
    binary,
    function
  } kind;
  double value = 0;
  int index = -1;                        ///< variable index
  char op = 0;                           ///< + - * / ^ < > l (<=) g (>=)
  std::string name;                      ///< function name
  std::vector<std::shared_ptr<const Node>> args;

  double eval(const double* v) const
  {
    switch (kind)
    {
    case number:
      return value;
    case variable:
      return v[index];
    case unary:
      return -args[0]->eval(v);
    case binary:
    {
      const double a = args[0]->eval(v), b = args[1]->eval(v);
      switch (op)
      {
      case '+': return a + b;
      case '-': return a - b;
      case '*': return a * b;
      case '/': return a / b;
      case '^': return std::pow(a, b);
      case '<': return a < b;
      case '>': return a > b;
      case 'l': return a <= b;
      default: return a >= b;
      }
    }
    default:
    {
      const double a = args[0]->eval(v);
      if (name == "min")
        return std::min(a, args[1]->eval(v));
      if (name == "max")
        return std::max(a, args[1]->eval(v));
      static const std::map<std::string, double (*)(double)> f
          = {{"sin", std::sin}, {"cos", std::cos}, {"tan", std::tan},
             {"exp", std::exp}, {"log", std::log}, {"sqrt", std::sqrt},
             {"abs", std::fabs}, {"tanh", std::tanh}};
      return f.at(name)(a);
    }
    }
  }
};

namespace
{
using NodePtr = std::shared_ptr<const Expression::Node>;

const std::map<std::string, int> functions
    = {{"sin", 1}, {"cos", 1}, {"tan", 1}, {"exp", 1}, {"log", 1}, {"sqrt", 1},
       {"abs", 1}, {"tanh", 1}, {"min", 2}, {"max", 2}};

/// Recursive descent: comparison > sum > product > unary > power > atom.
class Parser
{
public:
  Parser(const std::string& text, const std::vector<std::string>& variables)
      : _s(text), _variables(variables)
  {
  }

  NodePtr parse()
  {
    NodePtr n = comparison();
    skip();
    if (_i != _s.size())
      fail("unexpected '" + std::string(1, _s[_i]) + "'");
    return n;
  }

private:
  [[noreturn]] void fail(const std::string& what) const
  {
    throw InputError("expression '" + _s + "': " + what + " at character "
                     + std::to_string(_i + 1));
  }
  void skip()
  {
    while (_i < _s.size() and std::isspace(static_cast<unsigned char>(_s[_i])))
      ++_i;
  }
  bool accept(const std::string& token)
  {
    skip();
    if (_s.compare(_i, token.size(), token) == 0)
    {
      _i += token.size();
      return true;
    }
    return false;
  }
  NodePtr make_binary(char op, NodePtr a, NodePtr b)
  {
    count_node();
    auto n = std::make_shared<Expression::Node>();
    n->kind = Expression::Node::binary;
    n->op = op;
    n->args = {a, b};
    return n;
  }

  NodePtr comparison()
  {
    NodePtr a = sum();
    for (;;)
    {
      if (accept("<="))
        a = make_binary('l', a, sum());
      else if (accept(">="))
        a = make_binary('g', a, sum());
      else if (accept("<"))
        a = make_binary('<', a, sum());
      else if (accept(">"))
        a = make_binary('>', a, sum());
      else
        return a;
    }
  }
  NodePtr sum()
  {
    NodePtr a = product();
    for (;;)
    {
      if (accept("+"))
        a = make_binary('+', a, product());
      else if (accept("-"))
        a = make_binary('-', a, product());
      else
        return a;
    }
  }
  NodePtr product()
  {
    NodePtr a = signed_power();
    for (;;)
    {
      if (accept("*"))
        a = make_binary('*', a, signed_power());
      else if (accept("/"))
        a = make_binary('/', a, signed_power());
      else
        return a;
    }
  }
  // Every recursion passes through here: bounded depth, bounded size (the
  // tree is evaluated recursively too)
  void count_node()
  {
    if (++_nodes > 10000)
      fail("formula too long (more than 10000 operations)");
  }
  struct Depth
  {
    Parser& p;
    explicit Depth(Parser& parser) : p(parser)
    {
      if (++p._depth > 200)
        p.fail("nesting too deep");
    }
    ~Depth() { --p._depth; }
  };

  // -x^2 = -(x^2), as in mathematics
  NodePtr signed_power()
  {
    const Depth guard(*this);
    count_node();
    if (accept("-"))
    {
      auto n = std::make_shared<Expression::Node>();
      n->kind = Expression::Node::unary;
      n->args = {signed_power()};
      return n;
    }
    if (accept("+"))
      return signed_power();
    return power();
  }
  NodePtr power()
  {
    NodePtr base = atom();
    if (accept("^"))
      return make_binary('^', base, signed_power());
    return base;
  }
  NodePtr atom()
  {
    skip();
    if (_i >= _s.size())
      fail("unexpected end, expected a number, variable or '('");
    NodePtr result;
    const char c = _s[_i];
    if (accept("("))
    {
      result = comparison();
      if (!accept(")"))
        fail("expected ')'");
    }
    else if (std::isdigit(static_cast<unsigned char>(c)) or c == '.')
    {
      const char* begin = _s.c_str() + _i;
      char* end = nullptr;
      const double value = std::strtod(begin, &end);
      if (end == begin)
        fail("malformed number");
      _i += end - begin;
      auto n = std::make_shared<Expression::Node>();
      n->kind = Expression::Node::number;
      n->value = value;
      result = n;
    }
    else if (std::isalpha(static_cast<unsigned char>(c)) or c == '_')
    {
      const std::size_t start = _i;
      while (_i < _s.size()
             and (std::isalnum(static_cast<unsigned char>(_s[_i])) or _s[_i] == '_'))
        ++_i;
      const std::string name = _s.substr(start, _i - start);
      auto n = std::make_shared<Expression::Node>();
      if (auto f = functions.find(name); f != functions.end())
      {
        if (!accept("("))
          fail("expected '(' after " + name);
        n->kind = Expression::Node::function;
        n->name = name;
        n->args.push_back(comparison());
        for (int k = 1; k < f->second; ++k)
        {
          if (!accept(","))
            fail(name + " takes " + std::to_string(f->second) + " arguments");
          n->args.push_back(comparison());
        }
        if (!accept(")"))
          fail("expected ')' closing " + name);
      }
      else if (name == "pi")
      {
        n->kind = Expression::Node::number;
        n->value = std::numbers::pi;
      }
      else
      {
        std::size_t k = 0;
        while (k < _variables.size() and _variables[k] != name)
          ++k;
        if (k == _variables.size())
        {
          std::vector<std::string> known = _variables;
          for (auto& [f, _] : functions)
            known.push_back(f);
          throw InputError("expression '" + _s + "': unknown name '" + name
                           + "'; variables: " + join(_variables) + ", functions: "
                           + "sin cos tan exp log sqrt abs tanh min max"
                           + did_you_mean(name, known));
        }
        n->kind = Expression::Node::variable;
        n->index = static_cast<int>(k);
      }
      result = n;
    }
    else
      fail("unexpected '" + std::string(1, c) + "'");
    return result;
  }

  const std::string& _s;
  const std::vector<std::string>& _variables;
  std::size_t _i = 0;
  int _depth = 0, _nodes = 0;
};

bool uses_index(const Expression::Node& n, int index)
{
  if (n.kind == Expression::Node::variable and n.index == index)
    return true;
  for (const auto& a : n.args)
    if (uses_index(*a, index))
      return true;
  return false;
}
} // namespace

Expression::Expression(const std::string& text, const std::vector<std::string>& variables)
    : _text(text), _variables(variables), _root(Parser(_text, _variables).parse())
{
}

Expression::~Expression() = default;
Expression::Expression(const Expression&) = default;
Expression& Expression::operator=(const Expression&) = default;

double Expression::operator()(const double* values) const { return _root->eval(values); }

bool Expression::uses(const std::string& variable) const
{
  for (std::size_t k = 0; k < _variables.size(); ++k)
    if (_variables[k] == variable)
      return uses_index(*_root, static_cast<int>(k));
  return false;
}

} // namespace muscle
