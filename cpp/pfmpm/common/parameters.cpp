/// @file parameters.cpp
/// @brief Declared parameters: the check of given values against their declarations.
#include "pfmpm/common/parameters.h"

#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

namespace pfmpm
{

ParameterSpec ParameterSpec::number(std::string name, std::string unit, std::string doc)
{
  ParameterSpec s;
  s.name = std::move(name);
  s.unit = std::move(unit);
  s.doc = std::move(doc);
  return s;
}

ParameterSpec ParameterSpec::integer(std::string name, std::string doc)
{
  ParameterSpec s = number(std::move(name), "1", std::move(doc));
  s.kind = ParameterKind::integer;
  return s;
}

ParameterSpec ParameterSpec::word(std::string name, std::vector<std::string> choices,
                                  std::string doc)
{
  ParameterSpec s;
  s.name = std::move(name);
  s.kind = ParameterKind::word;
  s.choices = std::move(choices);
  s.doc = std::move(doc);
  return s;
}

ParameterSpec ParameterSpec::above(double x) const
{
  ParameterSpec s = *this;
  s.lower = x;
  s.lower_open = true;
  return s;
}

ParameterSpec ParameterSpec::at_least(double x) const
{
  ParameterSpec s = *this;
  s.lower = x;
  s.lower_open = false;
  return s;
}

ParameterSpec ParameterSpec::below(double x) const
{
  ParameterSpec s = *this;
  s.upper = x;
  s.upper_open = true;
  return s;
}

ParameterSpec ParameterSpec::at_most(double x) const
{
  ParameterSpec s = *this;
  s.upper = x;
  s.upper_open = false;
  return s;
}

ParameterSpec ParameterSpec::fallback(double x) const
{
  ParameterSpec s = *this;
  s.number_default = x;
  return s;
}

ParameterSpec ParameterSpec::fallback(std::string w) const
{
  ParameterSpec s = *this;
  s.word_default = std::move(w);
  return s;
}

ParameterSpec ParameterSpec::from(std::string path) const
{
  ParameterSpec s = *this;
  s.set_by = std::move(path);
  return s;
}

ParameterSpec ParameterSpec::when_needed() const
{
  ParameterSpec s = *this;
  s.optional = true;
  return s;
}

namespace
{
std::string number_text(double x)
{
  std::ostringstream out;
  out << x;
  return out.str();
}
} // namespace

std::string ParameterSpec::rule() const
{
  if (kind == ParameterKind::word)
  {
    std::string out = "must be one of";
    for (std::size_t i = 0; i < choices.size(); ++i)
      out += (i ? ", " : " ") + choices[i];
    return out;
  }
  std::vector<std::string> parts;
  if (std::isfinite(lower))
    parts.push_back((lower_open ? "> " : ">= ") + number_text(lower));
  if (std::isfinite(upper))
    parts.push_back((upper_open ? "< " : "<= ") + number_text(upper));
  std::string out = kind == ParameterKind::integer ? "must be a whole number" : "";
  for (std::size_t i = 0; i < parts.size(); ++i)
    out += (out.empty() ? "must be " : " and ") + parts[i];
  return out;
}

double ParameterSpec::check(double x) const
{
  const bool whole = kind != ParameterKind::integer || x == std::floor(x);
  const bool above = lower_open ? x > lower : x >= lower;
  const bool below = upper_open ? x < upper : x <= upper;
  if (!std::isfinite(x) || !whole || !above || !below)
    throw std::invalid_argument(refusal(name, x, rule().empty() ? "must be finite" : rule()));
  return x;
}

const ParameterSpec& declared(const std::vector<ParameterSpec>& specs, const std::string& name)
{
  for (const ParameterSpec& s : specs)
    if (s.name == name)
      return s;
  throw std::logic_error("no parameter " + name + " is declared");
}

std::string refusal(const std::string& name, double value, const std::string& rule)
{
  std::ostringstream msg;
  msg << name << " = " << value << ": " << rule;
  return msg.str();
}

Parameters Parameters::checked(const std::string& model,
                               const std::vector<ParameterSpec>& specs) const
{
  std::set<std::string> declared;
  Parameters out;
  for (const ParameterSpec& s : specs)
  {
    declared.insert(s.name);
    if (s.kind == ParameterKind::word)
    {
      if (_numbers.count(s.name))
        throw std::invalid_argument(refusal(s.name, _numbers.at(s.name), s.rule()));
      const auto it = _words.find(s.name);
      if (it == _words.end() && s.optional && !s.word_default)
        continue;
      if (it == _words.end() && !s.word_default)
        throw std::invalid_argument(s.name + ": missing (the " + model + " model needs it)");
      const std::string& w = it != _words.end() ? it->second : *s.word_default;
      bool known = false;
      for (const std::string& c : s.choices)
        known = known || c == w;
      if (!known)
        throw std::invalid_argument(s.name + " = " + w + ": " + s.rule());
      out._words[s.name] = w;
      continue;
    }
    if (_words.count(s.name))
      throw std::invalid_argument(s.name + " = " + _words.at(s.name) + ": must be a number");
    const auto it = _numbers.find(s.name);
    if (it == _numbers.end() && s.optional && !s.number_default)
      continue;
    if (it == _numbers.end() && !s.number_default)
      throw std::invalid_argument(s.name + ": missing (the " + model + " model needs it)");
    out._numbers[s.name] = s.check(it != _numbers.end() ? it->second : *s.number_default);
  }
  for (const auto& [key, value] : _numbers)
    if (!declared.count(key))
      throw std::invalid_argument(key + ": not a parameter of the " + model + " model");
  for (const auto& [key, value] : _words)
    if (!declared.count(key))
      throw std::invalid_argument(key + ": not a parameter of the " + model + " model");
  return out;
}

double Parameters::number(const std::string& key) const
{
  const auto it = _numbers.find(key);
  if (it == _numbers.end())
    throw std::logic_error("the number " + key + " was not declared");
  return it->second;
}

const std::string& Parameters::word(const std::string& key) const
{
  const auto it = _words.find(key);
  if (it == _words.end())
    throw std::logic_error("the word " + key + " was not declared");
  return it->second;
}

} // namespace pfmpm
