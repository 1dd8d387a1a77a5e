#include "common/errors.h"

#include <cmath>

#include <algorithm>
#include <cctype>
#include <numeric>

namespace muscle
{

std::optional<double> parse_real(const std::string& text, bool finite)
{
  std::size_t used = 0;
  double value = 0;
  try
  {
    value = std::stod(text, &used);
  }
  catch (const std::exception&)
  {
    return std::nullopt;
  }
  if (used == 0 or used != text.size() or std::isnan(value) or (finite and std::isinf(value)))
    return std::nullopt;
  return value;
}

std::size_t edit_distance(const std::string& a, const std::string& b)
{
  std::vector<std::size_t> row(b.size() + 1);
  std::iota(row.begin(), row.end(), 0);
  for (std::size_t i = 1; i <= a.size(); ++i)
  {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
    {
      const std::size_t above = row[j];
      const bool same = std::tolower(a[i - 1]) == std::tolower(b[j - 1]);
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string nearest(const std::string& word,
                    const std::vector<std::string>& candidates)
{
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const std::string& c : candidates)
  {
    const std::size_t d = edit_distance(word, c);
    if (d < best_distance)
    {
      best = c;
      best_distance = d;
    }
  }
  return best;
}

std::string join(const std::vector<std::string>& items,
                 const std::string& separator)
{
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i)
    out += (i ? separator : "") + items[i];
  return out;
}

std::string did_you_mean(const std::string& word,
                         const std::vector<std::string>& candidates)
{
  const std::string n = nearest(word, candidates);
  return n.empty() ? "" : " (did you mean '" + n + "'?)";
}

} // namespace muscle
