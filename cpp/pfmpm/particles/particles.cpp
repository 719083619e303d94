/// @file particles.cpp
/// @brief Core particle arrays and named columns.
#include "pfmpm/particles/particles.h"

#include "pfmpm/common/symmetric.h"

#include <array>
#include <numeric>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
/// The core arrays of particles in `dim` directions, in the order of
/// Particles::columns().
const std::array<ColumnSpec, 9>& core_specs(int dim)
{
  static const std::array<ColumnSpec, 9> plane{{
      {"x", 2, DType::f64, {0.0}, "position", "x,y", ""},
      {"v", 2, DType::f64, {0.0}, "velocity (K&T eq. 80)", "x,y", "velocity"},
      {"mass", 1, DType::f64, {0.0}, "mass M_p", "", ""},
      {"volume", 1, DType::f64, {0.0}, "current volume V_p", "", "volume"},
      {"stress", symmetric_size(2), DType::f64, {0.0}, "Cauchy stress", "xx,yy,xy,zz", "stress"},
      {"fext", 2, DType::f64, {0.0}, "external force (K&T eq. 42)", "x,y", ""},
      {"body", 1, DType::i32, {0.0}, "body index", "", "body"},
      {"material", 1, DType::i32, {0.0}, "material index", "", "material"},
      {"id", 1, DType::i64, {0.0}, "global id: body and place in its seeding lattice", "", "id"},
  }};
  static const std::array<ColumnSpec, 9> solid{{
      {"x", 3, DType::f64, {0.0}, "position", "x,y,z", ""},
      {"v", 3, DType::f64, {0.0}, "velocity (K&T eq. 80)", "x,y,z", "velocity"},
      {"mass", 1, DType::f64, {0.0}, "mass M_p", "", ""},
      {"volume", 1, DType::f64, {0.0}, "current volume V_p", "", "volume"},
      {"stress", symmetric_size(3), DType::f64, {0.0}, "Cauchy stress", "xx,yy,xy,zz,yz,xz", "stress"},
      {"fext", 3, DType::f64, {0.0}, "external force (K&T eq. 42)", "x,y,z", ""},
      {"body", 1, DType::i32, {0.0}, "body index", "", "body"},
      {"material", 1, DType::i32, {0.0}, "material index", "", "material"},
      {"id", 1, DType::i64, {0.0}, "global id: body and place in its seeding lattice", "", "id"},
  }};
  return dim == 2 ? plane : solid;
}

int checked_dim(int dim)
{
  if (dim != 2 && dim != 3)
    throw std::invalid_argument("particles in " + std::to_string(dim)
                                + " directions: must be 2 or 3");
  return dim;
}
} // namespace

Particles::Particles(std::size_t n, int dim)
    : x(checked_dim(dim) * n, 0.0), v(dim * n, 0.0), mass(n, 0.0), volume(n, 0.0),
      stress(symmetric_size(dim) * n, 0.0), fext(dim * n, 0.0), body(n, 0), material(n, 0), id(n),
      _dim(dim)
{
  std::iota(id.begin(), id.end(), std::int64_t{0});
}

void Particles::check_order() const
{
  for (std::size_t p = 1; p < id.size(); ++p)
    if (id[p] <= id[p - 1])
      throw std::invalid_argument("particle " + std::to_string(p) + ": id " + std::to_string(id[p])
                                  + " after id " + std::to_string(id[p - 1])
                                  + " (the particles must be in ascending id order)");
}

void Particles::resize(std::size_t n)
{
  x.resize(_dim * n);
  v.resize(_dim * n);
  mass.resize(n);
  volume.resize(n);
  stress.resize(symmetric_size(_dim) * n);
  fext.resize(_dim * n);
  body.resize(n);
  material.resize(n);
  id.resize(n);
  for (Column& c : _columns)
  {
    const auto k = static_cast<std::size_t>(c.spec.components);
    if (c.spec.dtype == DType::f64)
      c.f64.resize(k * n);
    else
      c.i32.resize(k * n);
  }
}

Column& Particles::add(const ColumnSpec& spec)
{
  for (const ColumnSpec& core : core_specs(_dim))
    if (core.name == spec.name)
      throw std::invalid_argument("particle column " + spec.name + ": a core array has that name");
  if (spec.dtype == DType::i64)
    throw std::invalid_argument("particle column " + spec.name + ": int64 is the ids' type, not a column's");
  const auto k = static_cast<std::size_t>(spec.components);
  if (spec.components < 1 || (spec.fill.size() != 1 && spec.fill.size() != k))
    throw std::invalid_argument("particle column " + spec.name + ": "
                                + std::to_string(spec.components) + " components, "
                                + std::to_string(spec.fill.size()) + " fill values");
  if (Column* c = find(spec.name))
  {
    if (c->spec.components != spec.components || c->spec.dtype != spec.dtype)
      throw std::invalid_argument("particle column " + spec.name + ": declared with "
                                  + std::to_string(c->spec.components) + " and "
                                  + std::to_string(spec.components) + " components");
    return *c;
  }
  Column& c = _columns.emplace_back(Column{spec, {}, {}});
  std::vector<double> row(k);
  for (std::size_t j = 0; j < k; ++j)
    row[j] = spec.fill[spec.fill.size() == 1 ? 0 : j];
  if (spec.dtype == DType::f64)
    c.f64.resize(size() * k);
  else
    c.i32.resize(size() * k);
  for (std::size_t p = 0; p < size(); ++p)
    for (std::size_t j = 0; j < k; ++j)
      if (spec.dtype == DType::f64)
        c.f64[p * k + j] = row[j];
      else
        c.i32[p * k + j] = static_cast<std::int32_t>(row[j]);
  return c;
}

Column* Particles::find(std::string_view name)
{
  for (Column& c : _columns)
    if (c.spec.name == name)
      return &c;
  return nullptr;
}

const Column* Particles::find(std::string_view name) const
{
  return const_cast<Particles*>(this)->find(name);
}

std::vector<double>& Particles::f64(std::string_view name)
{
  Column* c = find(name);
  if (!c || c->spec.dtype != DType::f64)
    throw std::out_of_range("no float64 particle column " + std::string(name));
  return c->f64;
}

const std::vector<double>& Particles::f64(std::string_view name) const
{
  return const_cast<Particles*>(this)->f64(name);
}

std::vector<std::int32_t>& Particles::i32(std::string_view name)
{
  Column* c = find(name);
  if (!c || c->spec.dtype != DType::i32)
    throw std::out_of_range("no int32 particle column " + std::string(name));
  return c->i32;
}

std::vector<Particles::Entry> Particles::columns()
{
  const auto& core = core_specs(_dim);
  std::vector<Entry> out{
      {&core[0], x.data(), x.size()},           {&core[1], v.data(), v.size()},
      {&core[2], mass.data(), mass.size()},     {&core[3], volume.data(), volume.size()},
      {&core[4], stress.data(), stress.size()}, {&core[5], fext.data(), fext.size()},
      {&core[6], body.data(), body.size()},     {&core[7], material.data(), material.size()},
      {&core[8], id.data(), id.size()}};
  for (Column& c : _columns)
    out.push_back({&c.spec, c.data(), c.values()});
  return out;
}

} // namespace pfmpm
