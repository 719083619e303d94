/// @file damage_fields.cpp
/// @brief The damage-field-gradient partition (H&H 2017 sections 2.1-2.4):
/// particle damage, kernel field, Algorithms 1 and 2, slots, surface flags.
#include "pfmpm/fields/damage_fields.h"
#include "pfmpm/common/stopwatch.h"
#include "pfmpm/common/vector.h"
#include "pfmpm/common/strips.h"
#include "pfmpm/fields/kernel.h"
#include "pfmpm/shape/cpdi.h"
#include "pfmpm/shape/stencil.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace pfmpm
{

namespace
{
/// Group of each particle: its body's, or the body itself when `groups` is empty.
std::vector<std::int32_t> particle_groups(const Particles& particles,
                                          const std::vector<std::int32_t>& groups, int n)
{
  std::vector<std::int32_t> out(particles.size());
  for (std::size_t p = 0; p < particles.size(); ++p)
  {
    const std::int32_t b = particles.body[p];
    std::int32_t g = b;
    if (!groups.empty())
    {
      if (b < 0 || static_cast<std::size_t>(b) >= groups.size())
        throw std::invalid_argument("particle " + std::to_string(p) + ": body " + std::to_string(b)
                                    + " has no contact group (groups has "
                                    + std::to_string(groups.size()) + " entries)");
      g = groups[b];
    }
    if (g < 0 || g >= n)
      throw std::invalid_argument("particle " + std::to_string(p) + ": contact group "
                                  + std::to_string(g) + " is not in [0, " + std::to_string(n) + ")");
    out[p] = g;
  }
  return out;
}

void check_option(bool ok, const std::string& name, double value, const char* rule)
{
  if (!ok)
    throw std::invalid_argument(name + " = " + std::to_string(value) + ": must be " + rule);
}
} // namespace

std::vector<ParameterSpec> DamageGradientOptions::parameters()
{
  using P = ParameterSpec;
  const DamageGradientOptions d;
  return {P::number("separability", "1",
                    "D-bar_min of the separability test (H&H eq. 21): two fields may part where "
                    "both their mean damages exceed it")
              .above(0.0)
              .below(1.0)
              .fallback(d.separability),
          P::number("kernel_radius", "length",
                    "kernel radius r_p of the damage field (H&H eqs. 17-19); 0: the cell diagonal, "
                    "the paper's")
              .at_least(0.0)
              .fallback(d.kernel_radius),
          P::number("skin", "1", "Verlet skin over r_p of the neighbour lists").above(0.0).fallback(d.skin),
          P::number("phase_field_threshold", "1", "c at or below which a phase-field particle is fully damaged")
              .at_least(0.0)
              .below(1.0)
              .fallback(d.phase_field_threshold),
          P::word("parting", {"softened", "failed"},
                  "when a group's fields may part at a node: once no damage-model particle there is "
                  "still softening, or by H&H eq. 21 alone (docs/contact.md, \"Parting\")")
              .fallback(d.part_when_softened ? "softened" : "failed")};
}

DamageGradientOptions DamageGradientOptions::from(std::vector<std::int32_t> groups, const Parameters& given)
{
  const Parameters p = given.checked("damage_gradient", parameters());
  DamageGradientOptions o;
  o.groups = std::move(groups);
  o.separability = p.number("separability");
  o.kernel_radius = p.number("kernel_radius");
  o.skin = p.number("skin");
  o.phase_field_threshold = p.number("phase_field_threshold");
  o.part_when_softened = p.word("parting") == "softened";
  return o;
}

template <int Dim>
KernelField kernel_damage_field(const Grid<Dim>& grid, const std::vector<double>& x,
                                const std::vector<double>& damage, double radius)
{
  const std::size_t n = x.size() / Dim;
  if (damage.size() != n)
    throw std::invalid_argument("damage: " + std::to_string(damage.size()) + " values for "
                                + std::to_string(n) + " particles");
  CellSort sort;
  if (const std::size_t outside = sort.sort(grid, x); outside < n)
    throw std::invalid_argument("particle " + std::to_string(outside) + " is outside the grid");
  NeighbourList<Dim> list;
  list.build(grid, sort, x, radius);
  KernelField out{std::vector<double>(n), std::vector<double>(n), std::vector<double>(Dim * n)};
  const auto np = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < np; ++p)
  {
    const auto listed = list.of(p);
    const KernelValue<Dim> v =
        kernel_field<Dim>(p, listed.first, listed.size, x.data(), damage.data(), radius);
    out.S[p] = v.S;
    out.D[p] = v.D;
    for (int d = 0; d < Dim; ++d)
      out.grad[Dim * p + d] = v.grad[d];
  }
  return out;
}

template KernelField kernel_damage_field(const Grid<2>&, const std::vector<double>&,
                                         const std::vector<double>&, double);
template KernelField kernel_damage_field(const Grid<3>&, const std::vector<double>&,
                                         const std::vector<double>&, double);

double lattice_kernel_sum(int dim, double spacing, double radius)
{
  if (dim != 2 && dim != 3)
    throw std::invalid_argument("dim = " + std::to_string(dim) + ": must be 2 or 3");
  const int n = static_cast<int>(std::ceil(radius / spacing));
  double S = 0.0;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      if (dim == 2)
        S += kernel_weight(std::hypot(i * spacing, j * spacing) / radius);
      else
        for (int k = -n; k <= n; ++k)
          S += kernel_weight(std::hypot(i * spacing, j * spacing, k * spacing) / radius);
  return S;
}

namespace
{
/// The distance between points a and b: std::hypot, of two or three differences.
template <int Dim>
double distance(const double* a, const double* b)
{
  if constexpr (Dim == 2)
    return std::hypot(a[0] - b[0], a[1] - b[1]);
  else
    return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/// The squared distance between points a and b, summed from the first direction.
template <int Dim>
double distance2(const double* a, const double* b)
{
  double e = a[0] - b[0];
  double sum = e * e;
  for (int d = 1; d < Dim; ++d)
  {
    e = a[d] - b[d];
    sum += e * e;
  }
  return sum;
}

/// Whether some entry of the Dim-vector v is not zero.
template <int Dim>
bool nonzero(const double* v)
{
  bool any = false;
  for (int d = 0; d < Dim; ++d)
    any = any || v[d] != 0.0;
  return any;
}
} // namespace

template <int Dim>
DamageFields<Dim>::DamageFields(const Grid<Dim>& grid, Particles& particles, std::vector<double> friction,
                                std::vector<DamageSource> source, DamageGradientOptions options)
    : _grid(grid), _friction(std::move(friction)), _source(std::move(source)),
      _options(std::move(options))
{
  _groups_n = friction_fields(_friction, 1);
  const DamageGradientOptions& o = _options;
  const auto specs = DamageGradientOptions::parameters();
  for (const auto& [name, value] : {std::pair<const char*, double>{"separability", o.separability},
                                    {"kernel_radius", o.kernel_radius},
                                    {"skin", o.skin},
                                    {"phase_field_threshold", o.phase_field_threshold}})
    declared(specs, name).check(value);
  check_option(o.full_damage > 0.0 && o.full_damage <= 1.0, "full_damage", o.full_damage,
               "in (0, 1]");
  if (_groups_n > max_groups)
    throw std::invalid_argument("friction: " + std::to_string(_groups_n) + " contact groups; at most "
                                + std::to_string(max_groups));
  // The cell diagonal, sqrt(Dim) h, unless given.
  _radius = o.kernel_radius > 0.0 ? o.kernel_radius : std::sqrt(double(Dim)) * grid.h();
  _group = particle_groups(particles, o.groups, _groups_n);
  if (_groups_n > 1)
    _groups.emplace(grid, particles, _friction, _group.data());
  particles.add({"damage_gradient", Dim, DType::f64, {0.0},
                 "gradient of the normalised kernel damage field at the particle (H&H eqs. 17-19), "
                 "where it partitions the fields (near nodes whose fields may separate), else 0",
                 Dim == 2 ? "x,y" : "x,y,z", "damage_gradient"});
  particles.add({"surface", 1, DType::i32, {0.0},
                 "surface flag s_p (H&H section 2.4): 1 on a surface, damage max(s_p, D_p)", "",
                 "surface"});
}

template <int Dim>
std::vector<double> DamageFields<Dim>::detect_surfaces(Particles& particles, const CellSort& sort,
                                                       const std::vector<double>& spacing,
                                                       double threshold)
{
  NeighbourList<Dim> list;
  list.build(_grid, sort, particles.x, _radius);
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  const double* x = particles.x.data();
  const std::int32_t* body = particles.body.data();
  std::int32_t* surface = particles.i32("surface").data();
  std::vector<double> bulk(spacing.size());
  for (std::size_t b = 0; b < spacing.size(); ++b)
  {
    if (!(spacing[b] > 0.0) || !std::isfinite(spacing[b]))
      throw std::invalid_argument("spacing[" + std::to_string(b) + "] = "
                                  + std::to_string(spacing[b]) + ": must be > 0");
    bulk[b] = lattice_kernel_sum(Dim, spacing[b], _radius);
  }
  for (std::ptrdiff_t p = 0; p < n; ++p)
    if (body[p] < 0 || static_cast<std::size_t>(body[p]) >= spacing.size())
      throw std::invalid_argument("particle " + std::to_string(p) + ": body " + std::to_string(body[p])
                                  + " has no lattice spacing");
  // Walls are mirror planes: per direction, the coordinates of a point and
  // of its images across the walled grid sides.
  std::array<std::array<double, 2>, Dim> plane{};
  std::array<std::array<bool, 2>, Dim> walled{};
  for (int d = 0; d < Dim; ++d)
  {
    const BSpline1D& b = _grid.basis(d);
    plane[d] = {b.origin(), b.origin() + b.length()};
    walled[d] = {_grid.wall(static_cast<Side>(2 * d)) != Wall::free,
                 _grid.wall(static_cast<Side>(2 * d + 1)) != Wall::free};
  }
  // The images of point q, combinations of its coordinate or an image of it
  // along each direction, the first direction slowest, q itself left out.
  constexpr int most_images = Dim == 2 ? 8 : 26;
  auto images = [&](const double* q, double (*out)[Dim])
  {
    double c[Dim][3];
    int m[Dim];
    for (int d = 0; d < Dim; ++d)
    {
      m[d] = 0;
      c[d][m[d]++] = q[d];
      for (int e = 0; e < 2; ++e)
        if (walled[d][e])
          c[d][m[d]++] = 2.0 * plane[d][e] - q[d];
    }
    int k = 0;
    int i[Dim] = {};
    for (;;)
    {
      int sum = 0;
      for (int d = 0; d < Dim; ++d)
        sum += i[d];
      if (sum > 0)
      {
        for (int d = 0; d < Dim; ++d)
          out[k][d] = c[d][i[d]];
        ++k;
      }
      int d = Dim - 1;
      for (; d >= 0 && ++i[d] == m[d]; --d)
        i[d] = 0;
      if (d < 0)
        return k;
    }
  };
  std::vector<double> ratio(particles.size());
  const double inv_r = 1.0 / _radius;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < n; ++p)
  {
    // H&H eq. 19 over p's own body and its mirror images in the walls (a face
    // on a wall, such as a symmetry plane, is no surface).
    const double* xp = &x[Dim * p];
    double S = 1.0;
    auto add = [&](const double* xq, bool self)
    {
      if (!self)
        S += kernel_weight(distance<Dim>(xp, xq) * inv_r);
      double image[most_images][Dim];
      const int k = images(xq, image);
      for (int i = 0; i < k; ++i)
        S += kernel_weight(distance<Dim>(xp, image[i]) * inv_r);
    };
    add(xp, true);
    for (const std::int32_t q : list.of(p))
    {
      if (body[q] == body[p])
        add(&x[Dim * q], false);
    }
    ratio[p] = S / bulk[body[p]];
    if (ratio[p] < threshold)
      surface[p] = 1;
  }
  return ratio;
}

template <int Dim>
bool DamageFields<Dim>::particle_damage(const Particles& particles, const CellSort& sort)
{
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  _damage.resize(n);
  _full.resize(n);
  _softening.resize(n);
  const Column* grew = particles.find("softening");
  const std::int32_t* softening = grew ? grew->i32.data() : nullptr;
  std::uint8_t* out_softening = _softening.data();
  _full_cell.assign(_grid.num_cells(), 0);
  std::uint8_t* full_cell = _full_cell.data();
  const std::int32_t* cell = sort.cell().data();
  const Column* column = particles.find("damage");
  const Column* phase = particles.find("c");
  const double* damage = column ? column->f64.data() : nullptr;
  const double* c = phase ? phase->f64.data() : nullptr;
  const std::int32_t* surface = particles.find("surface")->i32.data();
  const std::int32_t* material = particles.material.data();
  const DamageSource* source = _source.data();
  const double full_damage = _options.full_damage, full_c = _options.phase_field_threshold;
  // Local pointers: the byte store below may alias the vectors' own.
  double* out_damage = _damage.data();
  double* out_full = _full.data();
  int any = 0;
#pragma omp parallel for schedule(static) reduction(| : any)
  for (std::ptrdiff_t p = 0; p < n; ++p)
  {
    double D = 0.0;
    bool full = false;
    switch (source[material[p]])
    {
    case DamageSource::column:
      D = std::clamp(damage[p], 0.0, 1.0);
      full = D >= full_damage;
      break;
    case DamageSource::phase_field:
      D = std::clamp(1.0 - c[p], 0.0, 1.0);
      full = c[p] <= full_c;
      break;
    case DamageSource::none:
      break;
    }
    if (surface[p]) // max(s_p, D_p), section 2.4
    {
      D = 1.0;
      full = true;
    }
    out_damage[p] = D;
    out_full[p] = full ? 1.0 : 0.0;
    out_softening[p] = softening && source[material[p]] == DamageSource::column && !full
                           && softening[p] != 0;
    if (full)
    {
#pragma omp atomic write
      full_cell[cell[p]] = 1;
    }
    any |= full ? 1 : 0;
  }
  return any != 0;
}

namespace
{
/// n^Dim.
constexpr int power(int n, int dim) { return dim == 0 ? 1 : n * power(n, dim - 1); }

/// The group slots of a cell's stencil nodes, per group of the cell.
template <int Dim>
struct CellSlots
{
  /// Nodes of a cell's block: (degree + 1)^Dim with B-splines, 4^Dim with CPDI.
  static constexpr int K = std::max(power(max_degree + 1, Dim), power(4, Dim));
  static_assert(K <= 8 * static_cast<int>(sizeof(NodeMask<Dim>)), "a bit per node of the block");
  int n = 0;                                               ///< groups in the cell
  std::int32_t group[max_node_fields];                     ///< their indices, sorted
  std::int32_t slot[DamageFields<Dim>::max_groups][K];     ///< slot of group f at stencil node i
  /// Local index of group g (one of the cell's).
  int local(std::int32_t g) const
  {
    int f = 0;
    while (group[f] != g)
      ++f;
    return f;
  }
};

/// The groups of cell `cell` and their slots at its stencil nodes, in
/// stencil order (Grid::block(), the last direction fastest): looked up once
/// per cell, not per particle and node. `groups`: the group slots, or none
/// with one group (the slot of a node is then its active index). A line of
/// the block along the last direction is a run of consecutive active nodes.
template <int Dim>
void cell_slots(const Grid<Dim>& grid, const DamageFields<Dim>& fields,
                const std::optional<BodyFields<Dim>>& groups, const Cell<Dim>& cell, CellSlots<Dim>& c)
{
  const NodeBlock& block = grid.block();
  const int width = block.width;
  const std::array<int, Dim> nodes = grid.nodes();
  c.n = fields.cell_groups(cell.key, c.group);
  std::array<int, Dim> first, node;
  for (int d = 0; d < Dim; ++d)
    first[d] = block.first(cell.index[d], nodes[d]);
  const int lines = power(width, Dim - 1);
  for (int l = 0; l < lines; ++l)
  {
    node = first;
    for (int d = Dim - 2, rest = l; d >= 0; --d, rest /= width)
      node[d] += rest % width;
    const std::int32_t row = grid.active().index(node);
    for (int b = 0; b < width; ++b)
      for (int f = 0; f < c.n; ++f)
        c.slot[f][l * width + b] = groups ? groups->slot(row + b, c.group[f]) : row + b;
  }
}

/// f(cell, slots) for each occupied cell of `cells` (keys in increasing
/// order), with its group slots: cells of one strip parity in parallel
/// (for_each_listed_cell_by_strips), so that f may add into its cell's nodes.
template <int Dim, class F>
void for_each_listed_cell(const Grid<Dim>& grid, const DamageFields<Dim>& fields,
                          const std::optional<BodyFields<Dim>>& groups, const CellSort& sort,
                          const std::vector<std::int32_t>& cells, F&& f)
{
  for_each_listed_cell_by_strips<Dim>(grid.cells(), sort.cell_start(), cells,
                                      [&](const Cell<Dim>& cell)
                                      {
                                        CellSlots<Dim> c;
                                        cell_slots<Dim>(grid, fields, groups, cell, c);
                                        f(cell, c);
                                      });
}

/// The cells whose entry of `flag` is set, in key order, into `out` (the
/// passes over them skip the empty ones).
void list_cells(const std::vector<std::uint8_t>& flag, std::vector<std::int32_t>& out)
{
  out.clear();
  const auto ncells = static_cast<std::int32_t>(flag.size());
  for (std::int32_t c = 0; c < ncells; ++c)
    if (flag[c])
      out.push_back(c);
}

/// o[0, n) |= c[0, n), for byte flags: a function of its own, whose
/// arguments alias nothing, so that the loop vectorises (in the parallel
/// loop below, a byte store may alias the bounds it shares, which are then
/// read again at every element).
void or_into(std::uint8_t* __restrict o, const std::uint8_t* __restrict c, std::size_t n)
{
  for (std::size_t i = 0; i < n; ++i)
    o[i] |= c[i];
}

/// @brief Into `to`, the cells of `from` dilated by `reach` cells along
/// direction d of a lattice of `cells` cells: each cell ORed with the
/// cells up to `reach` away along d. Along the last direction a line's
/// entries are ORed shifted; along another, whole rows of the cells after d.
template <int Dim>
void dilate_along(const std::uint8_t* from, std::uint8_t* to, const std::array<int, Dim>& cells,
                  int d, int reach)
{
  std::size_t stride = 1, outer = 1;
  for (int e = d + 1; e < Dim; ++e)
    stride *= cells[e];
  for (int e = 0; e < d; ++e)
    outer *= cells[e];
  const int n = cells[d];
  const auto rows = static_cast<std::ptrdiff_t>(outer * n);
  std::fill(to, to + outer * n * stride, std::uint8_t{0});
  if (stride == 1)
  {
    // Lines along d: shifted copies of each line.
    const auto lines = static_cast<std::ptrdiff_t>(outer);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t l = 0; l < lines; ++l)
    {
      const std::size_t line = static_cast<std::size_t>(l) * n;
      for (int s = -reach; s <= reach; ++s)
      {
        const int first = std::max(0, -s), last = std::min(n, n - s);
        if (last > first)
          or_into(to + line + first, from + line + first + s, last - first);
      }
    }
    return;
  }
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t r = 0; r < rows; ++r)
  {
    const int c = static_cast<int>(r % n);
    for (int s = std::max(-reach, -c); s <= std::min(reach, n - 1 - c); ++s)
      or_into(to + static_cast<std::size_t>(r) * stride, from + static_cast<std::size_t>(r + s) * stride,
              stride);
  }
}

/// Into `out`, the cells within `reach` cells (along each axis) of a marked
/// cell of `in`: dilated along the last direction first, then along each
/// one before it, through `scratch`.
template <int Dim>
void dilate(const std::vector<std::uint8_t>& in, const std::array<int, Dim>& cells, int reach,
            std::vector<std::uint8_t>& scratch, std::vector<std::uint8_t>& out)
{
  scratch.resize(in.size());
  out.resize(in.size());
  const std::uint8_t* from = in.data();
  for (int d = Dim - 1; d >= 0; --d)
  {
    // Ending in `out`: the first direction writes it, the one before scratch.
    std::uint8_t* to = d % 2 == 0 ? out.data() : scratch.data();
    dilate_along<Dim>(from, to, cells, d, reach);
    from = to;
  }
}

/// The cells around the near cells (DamageFields::gradients) whose particles
/// the neighbour lists also hold.
constexpr int list_margin = 2;

} // namespace

template <int Dim>
template <class Stencil>
void DamageFields<Dim>::open_nodes(const Particles& particles, const CellSort& sort, const Points& points)
{
  constexpr int K = Stencil::size;
  const std::size_t ngs = num_group_slots();
  _mass.assign(ngs, 0.0);
  _mass_damage.assign(ngs, 0.0);
  _group_full.assign(ngs, 0);
  _group_softening.assign(ngs, 0);
  _open_slot.resize(ngs);
  const std::array<const BSpline1D*, Dim> basis = _grid.bases();
  const std::int32_t* order = sort.order().data();
  const std::int32_t* group = _group.data();
  const double* mass = particles.mass.data();
  const double* damage = _damage.data();
  const double* full = _full.data();
  const std::uint8_t* softening = _softening.data();
  // The sums of H&H eq. 21 over A and B together, with the terms P2G adds into
  // its md and full, cell by cell; strips of one parity share no node. On
  // the way, whether a particle of a near cell is missing from the
  // neighbour lists (gradients()).
  list_cells(_near, _near_cells);
  const bool lists = _neighbours.builds() > 0 && _neighbours.size() == particles.size();
  int unlisted = lists ? 0 : 1;
  for_each_listed_cell<Dim>(
      _grid, *this, _groups, sort, _near_cells,
      [&](const Cell<Dim>& cell, const CellSlots<Dim>& c)
      {
        double m[max_groups][K], md[max_groups][K];
        Mask any_full[max_groups], any_softening[max_groups];
        for (int f = 0; f < c.n; ++f) // the cell's groups only
        {
          std::fill_n(m[f], K, 0.0);
          std::fill_n(md[f], K, 0.0);
          any_full[f] = 0;
          any_softening[f] = 0;
        }
        for (std::int64_t k = cell.begin; k < cell.end; ++k)
        {
          const std::int32_t p = order[k];
          Stencil s;
          evaluate_at(s, basis, cell.index.data(), points, p);
          const int f = c.local(group[p]);
          const double mp = mass[p], Dp = damage[p];
          const bool failed = full[p] != 0.0, soft = softening[p] != 0;
          if (lists && !_neighbours.listed(p))
          {
#pragma omp atomic write
            unlisted = 1;
          }
          s.each_node(
              [&](int i, double w, const double*)
              {
                m[f][i] += w * mp;
                md[f][i] += w * mp * Dp;
                // Where its shape function is positive (CPDI: above round-off).
                const bool maps = Stencil::domains ? w > cpdi_maps_to : true;
                any_full[f] |= failed && maps ? Mask{1} << i : Mask{0};
                any_softening[f] |= soft && maps ? Mask{1} << i : Mask{0};
              });
        }
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < K; ++i)
          {
            const std::int32_t slot = c.slot[f][i];
            _mass[slot] += m[f][i];
            _mass_damage[slot] += md[f][i];
            _group_full[slot] |= static_cast<std::uint8_t>(any_full[f] >> i & 1u);
            _group_softening[slot] |= static_cast<std::uint8_t>(any_softening[f] >> i & 1u);
          }
      });
  _unlisted = unlisted != 0;
  // Open: a fully damaged particle maps there and the mean damage of both
  // sides together exceeds D-bar_min, less a margin far above the rounding
  // of sums of positive terms taken in another order than P2G's.
  const double threshold = _options.separability * (1.0 - 1e-9);
  const bool wait = _options.part_when_softened;
  const auto ngs_signed = static_cast<std::ptrdiff_t>(ngs);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t g = 0; g < ngs_signed; ++g)
    _open_slot[g] = _group_full[g] && _mass_damage[g] > threshold * _mass[g]
                            && !(wait && _group_softening[g])
                        ? 1
                        : 0;
  // The open cells: the occupied cells whose block holds an open node, found
  // from those nodes, which are few.
  _open.assign(_grid.num_cells(), 0);
  const std::int32_t na = _grid.num_active();
  for (std::int32_t a = 0; a < na; ++a)
  {
    const auto [g0, g1] = group_slots(a);
    std::uint8_t open = 0;
    for (std::int32_t g = g0; g < g1; ++g)
      open |= _open_slot[g];
    if (open)
      mark_holders(_grid, sort, a, nullptr, _open.data());
  }
  list_cells(_open, _open_cells);
}

template <int Dim>
void DamageFields<Dim>::open_cells(const Particles& particles, const CellSort& sort, const Points& points)
{
  // Cells within reach() cells of a fully damaged particle: only their
  // particles' stencils reach a node where one maps (the cells whose block
  // shares a node with a cell's are within reach() of it: the degree with
  // B-splines, up to 5 with CPDI's 4 x 4 blocks, which move inwards at the
  // grid's ends).
  dilate<Dim>(_full_cell, _grid.cells(), _grid.block().reach(), _dilated, _near);
  // The open nodes, with the transfers' shape functions.
  if (points.r1) // CPDI: the points carry domains
    open_nodes<CpdiStencil<Dim>>(particles, sort, points);
  else if (_grid.degree() == 1)
    open_nodes<BSplineStencil<Dim, 1>>(particles, sort, points);
  else if (_grid.degree() == 2)
    open_nodes<BSplineStencil<Dim, 2>>(particles, sort, points);
  else
    open_nodes<BSplineStencil<Dim, 3>>(particles, sort, points);
}

template <int Dim>
void DamageFields<Dim>::gradients(Particles& particles, const CellSort& sort)
{
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  const std::int32_t* cell_of = sort.cell().data(); // per particle, at this step's positions
  {
    Stopwatch clock{_timers.neighbours};
    // Only the particles of the near cells need a kernel field (those of the
    // open cells, and the neighbours within r_p that give the fully damaged
    // ones among them a side), so only theirs are listed, with those of the
    // cells within list_margin of them: the damage may spread that far
    // before the list lacks a particle it needs and is built again.
    // (open_nodes() noted an unlisted particle of a near cell as it passed.)
    if (_unlisted || _neighbours.stale(_grid, sort, particles.x, _options.skin * _radius))
    {
      dilate<Dim>(_near, _grid.cells(), list_margin, _dilated, _listed_cells);
      _neighbours.build(_grid, sort, particles.x, (1.0 + 2.0 * _options.skin) * _radius,
                        _listed_cells.data());
    }
  }
  Stopwatch clock{_timers.gradient};
  const double* x = particles.x.data();
  const double* damage = _damage.data();
  double* grad = particles.f64("damage_gradient").data();
  const NeighbourList<Dim>& list = _neighbours;
  const double radius = _radius;
  // Where every listed neighbour has p's damage, the kernel field is flat
  // and its gradient exactly zero (the sums of differences in kernel_field
  // vanish): a look at the damage alone.
  auto uniform = [&](std::int32_t p)
  {
    const double d = damage[p];
    for (const std::int32_t q : list.of(p))
      if (damage[q] != d)
        return false;
    return true;
  };
  const double reach2 = radius * radius;
  const double* full = _full.data();
  const std::int32_t* body = particles.body.data();
  // The kernel field's gradient at particle p into its column.
  std::uint8_t* set = _set.data();
  auto evaluate = [&](std::int32_t p)
  {
    const auto listed = list.of(p);
    const KernelValue<Dim> v = kernel_field<Dim>(p, listed.first, listed.size, x, damage, radius);
    for (int d = 0; d < Dim; ++d)
      grad[Dim * p + d] = v.grad[d];
    set[p] = 1;
  };
  std::int64_t evaluated = 0;
  int proxies = 0;
  _proxy.assign(particles.size(), 0);
  std::uint8_t* proxy = _proxy.data();
  // The particles of the open cells, whose stencils reach an open node
  // (clear() left every particle zero gradient and all pairs A; sides()
  // sets the open cells' masks).
  const auto nopen = static_cast<std::ptrdiff_t>(_open_cells.size());
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : evaluated) reduction(| : proxies)
  for (std::ptrdiff_t i = 0; i < nopen; ++i)
  {
    const std::int32_t c = _open_cells[i];
    for (std::int64_t k = start[c]; k < start[c + 1]; ++k)
    {
      const std::int32_t p = order[k];
      if (!uniform(p))
      {
        evaluate(p);
        ++evaluated;
      }
      // (A listed neighbour in the skin, beyond r_p, may differ where every
      // one within r_p has p's damage: the gradient is then zero all the
      // same, and p a flat particle like the uniform ones.)
      if (full[p] == 0.0 || nonzero<Dim>(&grad[Dim * p]))
        continue;
      // A fully damaged particle without a gradient takes its side from its
      // nearest neighbour of the same body with one within r_p (sides()):
      // those of them outside the open cells need theirs too.
      for (const std::int32_t q : list.of(p))
      {
        if (body[q] != body[p] || distance2<Dim>(&x[Dim * q], &x[Dim * p]) >= reach2)
          continue;
        const std::int32_t cell = cell_of[q];
        if (!_open[cell] && _near[cell])
        {
#pragma omp atomic write
          proxy[q] = 1;
          proxies = 1;
        }
      }
    }
  }
  // Those neighbours, evaluated where their damage varies (as in a near
  // cell of their own).
  if (proxies)
  {
    const auto n = static_cast<std::ptrdiff_t>(particles.size());
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : evaluated)
    for (std::ptrdiff_t q = 0; q < n; ++q)
      if (proxy[q] && !uniform(static_cast<std::int32_t>(q)))
      {
        evaluate(static_cast<std::int32_t>(q));
        ++evaluated;
      }
  }
  _evaluated += evaluated;
}

template <int Dim>
void DamageFields<Dim>::sides(const Particles& particles, const CellSort& sort, const Points& points,
                              const double* grad)
{
  constexpr int K = CellSlots<Dim>::K;
  const NodeBlock& block = _grid.block();
  const int nk = power(block.width, Dim);
  const std::size_t ngs = num_group_slots();
  _best_norm.assign(ngs, 0.0);
  _best.assign(ngs, -1);
  _has_b.assign(ngs, 0);
  const std::int32_t* order = sort.order().data();
  const std::int32_t* group = _group.data();
  const double* full = _full.data();
  // The nodes of its cell's block a particle maps to: all of them with
  // B-splines (positive on the whole cell); with CPDI (the particles carry
  // domains) those where its averaged shape function is positive, the
  // nodes of the cells its domain's corners lie in (above round-off:
  // cpdi_maps_to).
  const bool domains = points.r1 != nullptr;
  constexpr int bits = 8 * static_cast<int>(sizeof(Mask));
  const Mask all = nk >= bits ? ~Mask{0} : (Mask{1} << nk) - 1u;
  const std::array<const BSpline1D*, Dim> basis = _grid.bases();
  auto reached = [&](std::int32_t p, const Cell<Dim>& cell) -> Mask
  {
    if (!domains)
      return all;
    CpdiStencil<Dim> stencil;
    evaluate_at(stencil, basis, cell.index.data(), points, p);
    Mask m = 0;
    for (int i = 0; i < CpdiStencil<Dim>::size; ++i)
      m |= stencil.n[i] > cpdi_maps_to ? Mask{1} << i : Mask{0};
    return m;
  };
  // Algorithm 1, over the open cells (every cell whose block holds an open
  // node): per node and group, the particle gradient of largest magnitude,
  // ties to the smaller particle index, which is the smaller id (the
  // particles are in ascending id order: Particles::id). Each cell finds its
  // own best per node first (the largest, ties to the smaller index, is the
  // same in any order of comparison), then compares it with the node's.
  // Strips of one parity share no node, so the comparisons need no atomics.
  for_each_listed_cell<Dim>(
      _grid, *this, _groups, sort, _open_cells,
      [&](const Cell<Dim>& cell, const CellSlots<Dim>& c)
      {
        double norm[max_groups][K];
        std::int32_t best[max_groups][K];
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
          {
            norm[f][i] = 0.0;
            best[f][i] = -1;
          }
        for (std::int64_t k = cell.begin; k < cell.end; ++k)
        {
          const std::int32_t p = order[k];
          const double n2 = dot<Dim>(&grad[Dim * p], &grad[Dim * p]);
          if (n2 == 0.0)
            continue; // nothing to note
          const int f = c.local(group[p]);
          const Mask nodes = reached(p, cell);
          for (int i = 0; i < nk; ++i)
            if ((nodes >> i & 1u) && (n2 > norm[f][i] || (n2 == norm[f][i] && p < best[f][i])))
            {
              norm[f][i] = n2;
              best[f][i] = p;
            }
        }
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
          {
            const std::int32_t s = c.slot[f][i];
            const double n2 = norm[f][i];
            if (n2 > _best_norm[s] || (n2 > 0.0 && n2 == _best_norm[s] && best[f][i] < _best[s]))
            {
              _best_norm[s] = n2;
              _best[s] = best[f][i];
            }
          }
      });
  // Algorithm 2: field A where grad D_p . G_i >= 0, else B. A particle
  // whose kernel sees no damage variation (zero gradient), which a B-spline
  // stencil reaches past r_p, is placed by position if it is intact: on the
  // side of the node's gradient particle p* if it lies behind p* along G_i
  // (away from the damage), else on the other. A fully damaged one (inside
  // a flagged corner, where the kernel sees only flagged particles) takes
  // the side of its nearest neighbour of the same body with a
  // gradient within r_p, or A without one. Within r_p, not anywhere in
  // the list: the list also holds pairs in its skin, which depend on when
  // it was built, and a side taken from one of them made the run depend on
  // contact.skin; every pair within r_p is always listed.
  const std::int32_t* body = particles.body.data();
  const double reach2 = _radius * _radius;
  const double* x = particles.x.data();
  const NeighbourList<Dim>& list = _neighbours;
  // The nearest, the first in the list (the smallest index, so the smallest
  // id: NeighbourList) among equals;
  // without a branch per neighbour (which of them qualify is unpredictable
  // inside a fragment).
  auto proxy = [&](std::int32_t p)
  {
    std::int32_t best = -1;
    double closest = reach2;
    const std::int32_t bp = body[p];
    const double* xp = &x[Dim * p];
    for (const std::int32_t q : list.of(p))
    {
      const double d2 = body[q] == bp && nonzero<Dim>(&grad[Dim * q])
                            ? distance2<Dim>(&x[Dim * q], xp)
                            : reach2;
      best = d2 < closest ? q : best;
      closest = d2 < closest ? d2 : closest;
    }
    return best;
  };
  Mask* mask = _mask.data();
  std::uint8_t* set = _set.data();
  for_each_listed_cell<Dim>(
      _grid, *this, _groups, sort, _open_cells,
      [&](const Cell<Dim>& cell, const CellSlots<Dim>& c)
      {
        // Per group and node: G_i, and the position of its particle p*
        // (none: G_i = 0, and every pair chooses A); per group, whether
        // some node's G_i is not zero (else all its pairs choose A: the
        // sides below are +-0).
        double G[max_groups][K][Dim], star[max_groups][K][Dim];
        bool has_star[max_groups][K], live[max_groups] = {};
        Mask chose_b[max_groups] = {};
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
          {
            const std::int32_t s = c.slot[f][i], q = _best[s];
            const std::array<double, Dim> Gi = nodal_gradient(s, grad);
            for (int d = 0; d < Dim; ++d)
              G[f][i][d] = Gi[d];
            live[f] |= nonzero<Dim>(G[f][i]);
            has_star[f][i] = q >= 0;
            for (int d = 0; d < Dim; ++d)
              star[f][i][d] = q >= 0 ? x[Dim * q + d] : 0.0;
          }
        Mask any = 0;
        for (std::int64_t k = cell.begin; k < cell.end; ++k)
        {
          const std::int32_t p = order[k];
          const int f = c.local(group[p]);
          if (!live[f])
          {
            mask[p] = 0;
            continue;
          }
          const bool flat = !nonzero<Dim>(&grad[Dim * p]);
          const std::int32_t near = !flat ? p : full[p] != 0.0 ? proxy(p) : -1;
          Mask m = 0;
          if (near >= 0)
          {
            const double* g = &grad[Dim * near];
            for (int i = 0; i < nk; ++i)
            {
              const double side = dot<Dim>(g, G[f][i]);
              m |= side < 0.0 ? Mask{1} << i : Mask{0};
            }
          }
          else if (full[p] == 0.0)
          {
            const double* xp = &x[Dim * p];
            for (int i = 0; i < nk; ++i)
            {
              double behind[Dim];
              for (int d = 0; d < Dim; ++d)
                behind[d] = star[f][i][d] - xp[d];
              const double side = has_star[f][i] ? dot<Dim>(behind, G[f][i]) : 0.0;
              m |= side < 0.0 ? Mask{1} << i : Mask{0};
            }
          }
          if (domains)
            m &= reached(p, cell); // no side at a node the particle does not map to
          mask[p] = m;
          set[p] |= m != 0u ? 1 : 0;
          chose_b[f] |= m;
          any |= m;
        }
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
            if (chose_b[f] >> i & 1u)
              _has_b[c.slot[f][i]] = 1;
        _split[cell.key] = any != 0;
      });
}

template <int Dim>
void DamageFields<Dim>::layout(const CellSort& sort, bool any_split)
{
  const auto na = static_cast<std::ptrdiff_t>(_grid.num_active());
  if (!any_split)
    _has_b.assign(num_group_slots(), 0);
  _slot_start.resize(na + 1);
  _slot_start[0] = 0;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    const auto [g0, g1] = group_slots(static_cast<std::int32_t>(a));
    std::int32_t n = 0;
    for (std::int32_t g = g0; g < g1; ++g)
      n += 1 + _has_b[g];
    _slot_start[a + 1] = n;
  }
  std::int32_t contact = 0; // nodes with two or more fields
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    contact += _slot_start[a + 1] >= 2 ? 1 : 0;
    _slot_start[a + 1] += _slot_start[a];
  }
  _slot_field.resize(_slot_start[na]);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    const auto [g0, g1] = group_slots(static_cast<std::int32_t>(a));
    std::int32_t s = _slot_start[a];
    for (std::int32_t g = g0; g < g1; ++g)
    {
      const std::int32_t group = _groups ? _groups->field(g) : 0;
      _slot_field[s++] = 2 * group;
      if (_has_b[g])
        _slot_field[s++] = 2 * group + 1;
    }
  }

  // With one group, only a split node has two slots, and only open cells
  // have one among their nodes.
  const bool open_only = !_groups && any_split;
  mark_contact_cells(_grid, sort, _slot_start, contact, open_only ? _open.data() : nullptr,
                     _touches);
}

template <int Dim>
std::vector<std::array<double, 2 + Dim>> DamageFields<Dim>::nodal_gradients(const Particles& particles) const
{
  std::vector<std::array<double, 2 + Dim>> out;
  const std::int32_t na = _grid.num_active();
  const double* grad = particles.find("damage_gradient")->f64.data();
  for (std::int32_t a = 0; a < na; ++a)
  {
    const auto [g0, g1] = group_slots(a);
    for (std::int32_t g = g0; g < g1; ++g)
    {
      const std::array<double, Dim> G = _dirty && static_cast<std::size_t>(g) < _best.size()
                                            ? nodal_gradient(g, grad)
                                            : std::array<double, Dim>{};
      std::array<double, 2 + Dim> row{static_cast<double>(_grid.active_nodes()[a]),
                                      static_cast<double>(_groups ? _groups->field(g) : 0)};
      std::copy(G.begin(), G.end(), row.begin() + 2);
      out.push_back(row);
    }
  }
  return out;
}

template <int Dim>
void DamageFields<Dim>::clear(Particles& particles)
{
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  double* grad = particles.f64("damage_gradient").data();
  if (_clear_all || _mask.size() != particles.size())
  {
    _mask.assign(n, 0u);
    _set.assign(n, 0);
    std::fill(grad, grad + Dim * n, 0.0);
    _clear_all = false;
    return;
  }
  Mask* mask = _mask.data();
  std::uint8_t* set = _set.data();
  // Eight flags at a time: the set ones are few, near the damage.
  const std::ptrdiff_t words = (n + 7) / 8;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t w = 0; w < words; ++w)
  {
    const std::ptrdiff_t first = 8 * w, last = std::min(first + 8, n);
    std::uint64_t any = 0;
    std::memcpy(&any, set + first, static_cast<std::size_t>(last - first));
    if (any == 0)
      continue;
    for (std::ptrdiff_t p = first; p < last; ++p)
      if (set[p])
      {
        for (int d = 0; d < Dim; ++d)
          grad[Dim * p + d] = 0.0;
        mask[p] = 0u;
        set[p] = 0;
      }
  }
}

template <int Dim>
void DamageFields<Dim>::build(Particles& particles, const CellSort& sort, const Points& points)
{
  if (_groups)
    _groups->build(particles, sort, false);
  const auto ncells = static_cast<std::size_t>(_grid.num_cells());
  _split.assign(ncells, 0);
  clear(particles);
  bool any_full;
  {
    Stopwatch clock{_timers.damage};
    any_full = particle_damage(particles, sort);
    if (any_full)
      open_cells(particles, sort, points);
  }
  if (any_full)
  {
    gradients(particles, sort);
    Stopwatch clock{_timers.partition};
    sides(particles, sort, points, particles.f64("damage_gradient").data());
    _dirty = true;
  }
  else
    _dirty = false;
  Stopwatch clock{_timers.partition};
  layout(sort, any_full);
}

template class DamageFields<2>;
template class DamageFields<3>;

} // namespace pfmpm
