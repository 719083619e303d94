/// @file parameters.h
/// @brief Parameters declared once: a model states each parameter's name,
/// kind, bounds, default, unit and meaning, and everything else (the check of
/// a scene's values, the scene reader in Python, the reference tables of
/// docs/scenes.md) is derived from that declaration.
#pragma once

#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace pfmpm
{

/// What values a parameter takes.
enum class ParameterKind : int
{
  number = 0,  ///< a finite real
  integer = 1, ///< a whole number (held as a double)
  word = 2     ///< one of a list of words
};

/// @brief The declaration of one parameter of a model.
///
/// Built with the chainable setters: `ParameterSpec::number("E", "stress",
/// "Young's modulus").above(0)`.
struct ParameterSpec
{
  std::string name;
  ParameterKind kind = ParameterKind::number;
  /// The quantity's dimension in the scene's units: "stress", "density",
  /// "length", "energy/area", "speed", "time", "angle" (degrees) or "1"
  /// (dimensionless); empty for a word.
  std::string unit;
  std::string doc; ///< one sentence: what it is, with its paper equation
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  bool lower_open = false; ///< lower is excluded (value > lower)
  bool upper_open = false; ///< upper is excluded (value < upper)
  std::vector<std::string> choices; ///< the words a word parameter takes
  std::optional<double> number_default;
  std::optional<std::string> word_default;
  /// Where a scene takes the value from: empty, the model's own table (its
  /// key there is the name); otherwise the path of the entry that sets it,
  /// such as "plane" (the scene's) or "fracture.split".
  std::string set_by;
  /// Whether it may be absent with no default (one that only some choice of
  /// another parameter needs; the model checks Parameters::has()).
  bool optional = false;

  static ParameterSpec number(std::string name, std::string unit, std::string doc);
  static ParameterSpec integer(std::string name, std::string doc);
  static ParameterSpec word(std::string name, std::vector<std::string> choices, std::string doc);

  ParameterSpec above(double x) const;    ///< value > x
  ParameterSpec at_least(double x) const; ///< value >= x
  ParameterSpec below(double x) const;    ///< value < x
  ParameterSpec at_most(double x) const;  ///< value <= x
  ParameterSpec fallback(double x) const; ///< the default of a number
  ParameterSpec fallback(std::string w) const; ///< the default of a word
  ParameterSpec from(std::string path) const; ///< set_by
  ParameterSpec when_needed() const;          ///< optional

  bool required() const { return !number_default && !word_default && !optional; }
  /// The rule its values obey, as the error messages state it ("must be > 0
  /// and < 0.5", "must be one of euler, exponential"); empty if none.
  std::string rule() const;
  /// @brief The number x, if this declaration admits it.
  /// @throws std::invalid_argument "<name> = <x>: <rule>" otherwise.
  double check(double x) const;
};

/// @brief The declaration named `name` among `specs`.
/// @throws std::logic_error if there is none.
const ParameterSpec& declared(const std::vector<ParameterSpec>& specs, const std::string& name);

/// @brief A model's parameter values, checked against its declarations
/// (ParameterSpec) with the defaults filled in.
class Parameters
{
public:
  Parameters() = default;
  /// @brief The given numbers and words (a scene's table), unchecked.
  Parameters(std::map<std::string, double> numbers, std::map<std::string, std::string> words)
      : _numbers(std::move(numbers)), _words(std::move(words))
  {
  }
  /// @brief These values checked against `specs` of the model `model`,
  /// with the defaults of the absent ones.
  /// @throws std::invalid_argument naming the key, its value and the rule
  ///         for an unknown key, a missing one, a word where a number
  ///         belongs (or the reverse), or a value the declaration refuses.
  Parameters checked(const std::string& model, const std::vector<ParameterSpec>& specs) const;
  /// @brief The number `key` (declared: checked() supplied it).
  /// @throws std::logic_error if absent, a model reading what it did not declare.
  double number(const std::string& key) const;
  /// @brief The word `key`, likewise.
  const std::string& word(const std::string& key) const;
  /// Whether `key` was given or has a default.
  bool has(const std::string& key) const { return _numbers.count(key) || _words.count(key); }

private:
  std::map<std::string, double> _numbers;
  std::map<std::string, std::string> _words;
};

/// @brief The message of a refused value: "<name> = <value>: <rule>".
std::string refusal(const std::string& name, double value, const std::string& rule);

} // namespace pfmpm
