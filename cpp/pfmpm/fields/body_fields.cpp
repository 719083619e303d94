/// @file body_fields.cpp
/// @brief Discrete fields, one per body: cell tags and node slots (K&T Remark 4).
#include "pfmpm/fields/fields.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
/// Insert `f` into the sorted list out[0, n); false when it is full.
bool insert_sorted(std::int32_t f, std::int32_t* out, int& n, int capacity)
{
  int i = 0;
  while (i < n && out[i] < f)
    ++i;
  if (i < n && out[i] == f)
    return true;
  if (n == capacity)
    return false;
  for (int j = n; j > i; --j)
    out[j] = out[j - 1];
  out[i] = f;
  ++n;
  return true;
}
} // namespace

int friction_fields(const std::vector<double>& friction, int at_least)
{
  const int n = static_cast<int>(std::lround(std::sqrt(static_cast<double>(friction.size()))));
  if (n < at_least || static_cast<std::size_t>(n) * n != friction.size())
    throw std::invalid_argument("friction: " + std::to_string(friction.size())
                                + " entries; need fields x fields with at least "
                                + std::to_string(at_least) + (at_least == 1 ? " field" : " fields"));
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
    {
      const double mu = friction[a * n + b];
      if (!(mu >= 0.0) || !std::isfinite(mu) || mu != friction[b * n + a])
        throw std::invalid_argument("friction[" + std::to_string(a) + "][" + std::to_string(b)
                                    + "] = " + std::to_string(mu)
                                    + ": must be finite, >= 0 and symmetric");
    }
  return n;
}

template <int Dim>
BodyFields<Dim>::BodyFields(const Grid<Dim>& grid, const Particles& particles, std::vector<double> friction,
                       const std::int32_t* field)
    : _grid(grid), _field(field), _friction(std::move(friction))
{
  _fields = friction_fields(_friction, 2);
  const std::int32_t* of = _field ? _field : particles.body.data();
  for (std::size_t p = 0; p < particles.size(); ++p)
    if (const std::int32_t f = of[p]; f < 0 || f >= _fields)
      throw std::invalid_argument("particle " + std::to_string(p) + ": body index "
                                  + std::to_string(f) + " is not a field in [0, "
                                  + std::to_string(_fields) + ")");
}

template <int Dim>
int BodyFields<Dim>::cell_fields(std::size_t key, std::int32_t* out) const
{
  const std::int32_t tag = _cell_field[key];
  if (tag >= 0)
  {
    out[0] = tag;
    return 1;
  }
  const std::int32_t m = -2 - tag;
  std::copy(&_mixed_fields[_mixed_start[m]], &_mixed_fields[_mixed_start[m + 1]], out);
  return _mixed_start[m + 1] - _mixed_start[m];
}

template <int Dim>
int BodyFields<Dim>::node_fields(std::int32_t node, std::int32_t* out) const
{
  int n = 0;
  _grid.for_each_holder_cell(node,
                             [&](std::size_t key)
                             {
                               if (_cell_field[key] == -1)
                                 return true;
                               std::int32_t list[max_fields];
                               const int k = cell_fields(key, list);
                               for (int i = 0; i < k; ++i)
                                 if (!insert_sorted(list[i], out, n, max_fields))
                                 {
                                   n = -1;
                                   return false;
                                 }
                               return true;
                             });
  return n;
}

template <int Dim>
void BodyFields<Dim>::build(const Particles& particles, const CellSort& sort, bool mark_touches)
{
  const auto ncells = static_cast<std::ptrdiff_t>(_grid.num_cells());
  const std::int32_t* body = _field ? _field : particles.body.data();
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();

  // Cells: empty, one field, or mixed.
  _cell_field.resize(ncells);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
  {
    std::int32_t tag = -1;
    if (start[c] < start[c + 1])
    {
      tag = body[order[start[c]]];
      for (std::int64_t k = start[c] + 1; k < start[c + 1]; ++k)
        if (body[order[k]] != tag)
        {
          tag = -2;
          break;
        }
    }
    _cell_field[c] = tag;
  }
  // The fields of each mixed cell (a thin layer where bodies touch).
  _mixed_start.assign(1, 0);
  _mixed_fields.clear();
  for (std::ptrdiff_t c = 0; c < ncells; ++c)
    if (_cell_field[c] == -2)
    {
      std::int32_t list[max_fields];
      int n = 0;
      for (std::int64_t k = start[c]; k < start[c + 1]; ++k)
        if (!insert_sorted(body[order[k]], list, n, max_fields))
          throw std::runtime_error("contact: more than " + std::to_string(max_fields)
                                   + " bodies share one grid cell");
      _cell_field[c] = -2 - static_cast<std::int32_t>(_mixed_start.size() - 1);
      _mixed_fields.insert(_mixed_fields.end(), list, list + n);
      _mixed_start.push_back(static_cast<std::int32_t>(_mixed_fields.size()));
    }

  // Remark 4: one slot per field in a node's support; a node with two or more
  // is a contact node.
  const auto na = static_cast<std::ptrdiff_t>(_grid.num_active());
  const std::vector<std::int32_t>& nodes = _grid.active_nodes();
  _slot_start.resize(na + 1);
  _slot_start[0] = 0;
  _lone_field.resize(na);
  std::ptrdiff_t overflow = na;
#pragma omp parallel for schedule(static) reduction(min : overflow)
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    std::int32_t list[max_fields];
    const int n = node_fields(nodes[a], list);
    _slot_start[a + 1] = n;
    _lone_field[a] = n > 0 ? list[0] : -1; // for the nodes of one field, nearly all
    if (n < 0)
      overflow = std::min(overflow, a);
  }
  if (overflow < na)
    throw std::runtime_error("contact: more than " + std::to_string(max_fields)
                             + " bodies meet at grid node " + std::to_string(nodes[overflow]));
  std::int32_t contact = 0; // nodes with two or more fields
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    contact += _slot_start[a + 1] >= 2 ? 1 : 0;
    _slot_start[a + 1] += _slot_start[a];
  }
  _slot_field.resize(_slot_start[na]);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < na; ++a)
    if (_slot_start[a + 1] - _slot_start[a] == 1)
      _slot_field[_slot_start[a]] = _lone_field[a];
    else
      node_fields(nodes[a], &_slot_field[_slot_start[a]]);

  if (mark_touches)
    mark_contact_cells(_grid, sort, _slot_start, contact, nullptr, _touches);
}

template <int Dim>
void mark_holders(const Grid<Dim>& grid, const CellSort& sort, std::int32_t a,
                  const std::uint8_t* only, std::uint8_t* cells)
{
  const std::int64_t* start = sort.cell_start().data();
  grid.for_each_holder_cell(grid.active_nodes()[a],
                            [&](std::size_t cell)
                            {
                              if (start[cell + 1] > start[cell] && (!only || only[cell]))
                                cells[cell] = 1;
                              return true;
                            });
}

template <int Dim>
void mark_contact_cells(const Grid<Dim>& grid, const CellSort& sort,
                        const std::vector<std::int32_t>& slot_start, std::int32_t contact_nodes,
                        const std::uint8_t* only, std::vector<std::uint8_t>& touches)
{
  touches.assign(grid.num_cells(), 0);
  if (contact_nodes == 0)
    return;
  // From the contact nodes, which are few, to the cells whose blocks hold them.
  const std::int32_t na = grid.num_active();
  for (std::int32_t a = 0; a < na; ++a)
    if (slot_start[a + 1] - slot_start[a] >= 2)
      mark_holders(grid, sort, a, only, touches.data());
}

template class BodyFields<2>;
template class BodyFields<3>;
template void mark_holders(const Grid<2>&, const CellSort&, std::int32_t, const std::uint8_t*,
                           std::uint8_t*);
template void mark_holders(const Grid<3>&, const CellSort&, std::int32_t, const std::uint8_t*,
                           std::uint8_t*);
template void mark_contact_cells(const Grid<2>&, const CellSort&, const std::vector<std::int32_t>&,
                                 std::int32_t, const std::uint8_t*, std::vector<std::uint8_t>&);
template void mark_contact_cells(const Grid<3>&, const CellSort&, const std::vector<std::int32_t>&,
                                 std::int32_t, const std::uint8_t*, std::vector<std::uint8_t>&);

} // namespace pfmpm
