/// @file material.cpp
/// @brief The material registry and material parameters.
#include "pfmpm/materials/material.h"

#include <sstream>
#include <stdexcept>

namespace pfmpm
{

double Parameters::number(const std::string& key) const
{
  const auto it = _numbers.find(key);
  if (it == _numbers.end())
    throw std::invalid_argument(key + ": missing");
  _used.push_back(key);
  return it->second;
}

double Parameters::number(const std::string& key, double fallback) const
{
  return _numbers.count(key) ? number(key) : fallback;
}

std::string Parameters::word(const std::string& key, const std::string& fallback) const
{
  const auto it = _words.find(key);
  if (it == _words.end())
    return fallback;
  _used.push_back(key);
  return it->second;
}

void Parameters::finish(const std::string& model) const
{
  auto used = [this](const std::string& key)
  { return std::find(_used.begin(), _used.end(), key) != _used.end(); };
  for (const auto& [key, value] : _numbers)
    if (!used(key))
      throw std::invalid_argument(key + ": not a parameter of the " + model + " model");
  for (const auto& [key, value] : _words)
    if (!used(key))
      throw std::invalid_argument(key + ": not a parameter of the " + model + " model");
}

std::map<std::string, MaterialRegistry::Factory>& MaterialRegistry::table()
{
  static std::map<std::string, Factory> models;
  return models;
}

bool MaterialRegistry::add(const std::string& model, Factory factory)
{
  if (!table().emplace(model, std::move(factory)).second)
    throw std::logic_error("material model " + model + " registered twice");
  return true;
}

std::shared_ptr<Material> MaterialRegistry::make(const std::string& model,
                                                 const Parameters& parameters)
{
  const auto it = table().find(model);
  if (it == table().end())
  {
    std::ostringstream msg;
    msg << "model = " << model << ": unknown; the registered models are";
    for (const auto& [name, factory] : table())
      msg << " " << name;
    throw std::invalid_argument(msg.str());
  }
  std::shared_ptr<Material> m = it->second(parameters);
  parameters.finish(model);
  return m;
}

std::vector<std::string> MaterialRegistry::models()
{
  std::vector<std::string> out;
  for (const auto& [name, factory] : table())
    out.push_back(name);
  return out;
}

} // namespace pfmpm
