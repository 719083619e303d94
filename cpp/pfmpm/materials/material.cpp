/// @file material.cpp
/// @brief The material registry.
#include "pfmpm/materials/material.h"

#include <sstream>
#include <stdexcept>

namespace pfmpm
{

std::map<std::string, MaterialDeclaration>& MaterialRegistry::table()
{
  static std::map<std::string, MaterialDeclaration> models;
  return models;
}

bool MaterialRegistry::add(const std::string& model, MaterialDeclaration declaration)
{
  if (!table().emplace(model, std::move(declaration)).second)
    throw std::logic_error("material model " + model + " registered twice");
  return true;
}

const MaterialDeclaration& MaterialRegistry::declaration(const std::string& model)
{
  const auto it = table().find(model);
  if (it == table().end())
  {
    std::ostringstream msg;
    msg << "model = " << model << ": unknown; the registered models are";
    for (const auto& [name, declared] : table())
      msg << " " << name;
    throw std::invalid_argument(msg.str());
  }
  return it->second;
}

std::shared_ptr<Material> MaterialRegistry::make(const std::string& model, const Parameters& given)
{
  const MaterialDeclaration& d = declaration(model);
  return d.make(given.checked(model, d.parameters));
}

std::vector<std::string> MaterialRegistry::models()
{
  std::vector<std::string> out;
  for (const auto& [name, declared] : table())
    out.push_back(name);
  return out;
}

} // namespace pfmpm
