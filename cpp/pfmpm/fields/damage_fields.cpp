/// @file damage_fields.cpp
/// @brief The damage-field-gradient partition (H&H 2017 sections 2.1-2.4):
/// particle damage, kernel field, Algorithms 1 and 2, slots, surface flags.
#include "pfmpm/fields/damage_fields.h"
#include "pfmpm/common/stopwatch.h"
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

KernelField kernel_damage_field(const Grid<2>& grid, const std::vector<double>& x,
                                const std::vector<double>& damage, double radius)
{
  const std::size_t n = x.size() / 2;
  if (damage.size() != n)
    throw std::invalid_argument("damage: " + std::to_string(damage.size()) + " values for "
                                + std::to_string(n) + " particles");
  CellSort sort;
  if (const std::size_t outside = sort.sort(grid, x); outside < n)
    throw std::invalid_argument("particle " + std::to_string(outside) + " is outside the grid");
  NeighbourList list;
  list.build(grid, sort, x, radius);
  KernelField out{std::vector<double>(n), std::vector<double>(n), std::vector<double>(2 * n)};
  const auto np = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < np; ++p)
  {
    const auto listed = list.of(p);
    const KernelValue<2> v =
        kernel_field<2>(p, listed.first, listed.size, x.data(), damage.data(), radius);
    out.S[p] = v.S;
    out.D[p] = v.D;
    out.grad[2 * p] = v.grad[0];
    out.grad[2 * p + 1] = v.grad[1];
  }
  return out;
}

DamageFields::DamageFields(const Grid<2>& grid, Particles& particles, std::vector<double> friction,
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
  _radius = o.kernel_radius > 0.0 ? o.kernel_radius : std::sqrt(2.0) * grid.h();
  _group = particle_groups(particles, o.groups, _groups_n);
  if (_groups_n > 1)
    _groups.emplace(grid, particles, _friction, _group.data());
  particles.add({"damage_gradient", 2, DType::f64, {0.0},
                 "gradient of the normalised kernel damage field at the particle (H&H eqs. 17-19), "
                 "where it partitions the fields (near nodes whose fields may separate), else 0",
                 "x,y", "damage_gradient"});
  particles.add({"surface", 1, DType::i32, {0.0},
                 "surface flag s_p (H&H section 2.4): 1 on a surface, damage max(s_p, D_p)", "",
                 "surface"});
}

double DamageFields::lattice_kernel_sum(double spacing, double radius)
{
  const int n = static_cast<int>(std::ceil(radius / spacing));
  double S = 0.0;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      S += kernel_weight(std::hypot(i * spacing, j * spacing) / radius);
  return S;
}

std::vector<double> DamageFields::detect_surfaces(Particles& particles, const CellSort& sort,
                                                  const std::vector<double>& spacing,
                                                  double threshold)
{
  NeighbourList list;
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
    bulk[b] = lattice_kernel_sum(spacing[b], _radius);
  }
  for (std::ptrdiff_t p = 0; p < n; ++p)
    if (body[p] < 0 || static_cast<std::size_t>(body[p]) >= spacing.size())
      throw std::invalid_argument("particle " + std::to_string(p) + ": body " + std::to_string(body[p])
                                  + " has no lattice spacing");
  // Walls are mirror planes: per direction, the coordinates of a point and
  // of its images across the walled grid sides.
  std::array<std::array<double, 2>, 2> plane{};
  std::array<std::array<bool, 2>, 2> walled{};
  for (int d = 0; d < 2; ++d)
  {
    const BSpline1D& b = _grid.basis(d);
    plane[d] = {b.origin(), b.origin() + b.length()};
    walled[d] = {_grid.wall(static_cast<Side>(2 * d)) != Wall::free,
                 _grid.wall(static_cast<Side>(2 * d + 1)) != Wall::free};
  }
  auto images = [&](const double* q, double (*out)[2])
  {
    double c[2][3];
    int m[2];
    for (int d = 0; d < 2; ++d)
    {
      m[d] = 0;
      c[d][m[d]++] = q[d];
      for (int e = 0; e < 2; ++e)
        if (walled[d][e])
          c[d][m[d]++] = 2.0 * plane[d][e] - q[d];
    }
    int k = 0;
    for (int i = 0; i < m[0]; ++i)
      for (int j = 0; j < m[1]; ++j)
        if (i + j > 0)
        {
          out[k][0] = c[0][i];
          out[k++][1] = c[1][j];
        }
    return k;
  };
  std::vector<double> ratio(particles.size());
  const double inv_r = 1.0 / _radius;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t p = 0; p < n; ++p)
  {
    // H&H eq. 19 over p's own body and its mirror images in the walls (a face
    // on a wall, such as a symmetry plane, is no surface).
    const double* xp = &x[2 * p];
    double S = 1.0;
    auto add = [&](const double* xq, bool self)
    {
      if (!self)
        S += kernel_weight(std::hypot(xp[0] - xq[0], xp[1] - xq[1]) * inv_r);
      double image[8][2];
      const int k = images(xq, image);
      for (int i = 0; i < k; ++i)
        S += kernel_weight(std::hypot(xp[0] - image[i][0], xp[1] - image[i][1]) * inv_r);
    };
    add(xp, true);
    for (const std::int32_t q : list.of(p))
    {
      if (body[q] == body[p])
        add(&x[2 * q], false);
    }
    ratio[p] = S / bulk[body[p]];
    if (ratio[p] < threshold)
      surface[p] = 1;
  }
  return ratio;
}

bool DamageFields::particle_damage(const Particles& particles, const CellSort& sort)
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
/// The group slots of a cell's stencil nodes, per group of the cell.
struct CellSlots
{
  /// Nodes of a cell's block: (degree + 1)^2 with B-splines, 16 with CPDI.
  static constexpr int K = std::max((max_degree + 1) * (max_degree + 1), CpdiStencil<2>::size);
  int n = 0;                                       ///< groups in the cell
  std::int32_t group[max_node_fields];      ///< their indices, sorted
  std::int32_t slot[DamageFields::max_groups][K];  ///< slot of group f at stencil node i
  /// Local index of group g (one of the cell's).
  int local(std::int32_t g) const
  {
    int f = 0;
    while (group[f] != g)
      ++f;
    return f;
  }
};

/// The groups of cell (cx, cy) and their slots at its stencil nodes, in
/// stencil order (Grid::block()): looked up once per cell, not per particle
/// and node. `groups`: the group slots, or none with one group (the slot of
/// a node is then its active index).
void cell_slots(const Grid<2>& grid, const DamageFields& fields, const std::optional<BodyFields<2>>& groups,
                int cx, int cy, CellSlots& c)
{
  const NodeBlock& block = grid.block();
  const int width = block.width, ncy = grid.cells()[1];
  c.n = fields.cell_groups(static_cast<std::size_t>(cx) * ncy + cy, c.group);
  const int x0 = block.first(cx, grid.nodes()[0]), y0 = block.first(cy, grid.nodes()[1]);
  for (int a = 0; a < width; ++a)
  {
    const std::int32_t row = grid.active_index(x0 + a, y0);
    for (int b = 0; b < width; ++b)
      for (int f = 0; f < c.n; ++f)
        c.slot[f][a * width + b] = groups ? groups->slot(row + b, c.group[f]) : row + b;
  }
}

/// f(cx, cy, begin, end, slots) for each occupied cell (cx, cy) of `cells`
/// (keys in increasing order), its particles order[begin, end) of the sort
/// and its group slots: cells of one strip parity in parallel
/// (for_each_listed_cell_by_strips), so that f may add into its cell's nodes.
template <class F>
void for_each_listed_cell(const Grid<2>& grid, const DamageFields& fields,
                          const std::optional<BodyFields<2>>& groups, const CellSort& sort,
                          const std::vector<std::int32_t>& cells, F&& f)
{
  for_each_listed_cell_by_strips<2>(grid.cells(), sort.cell_start(), cells,
                                    [&](const Cell<2>& cell)
                                    {
                                      CellSlots c;
                                      cell_slots(grid, fields, groups, cell.index[0], cell.index[1], c);
                                      f(cell.index[0], cell.index[1], cell.begin, cell.end, c);
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
void or_into(std::uint8_t* __restrict o, const std::uint8_t* __restrict c, int n)
{
  for (int i = 0; i < n; ++i)
    o[i] |= c[i];
}

/// Into `out`, the cells within `reach` cells (along each axis) of a marked
/// cell of `in`: dilated along y into `along_y`, then along x, each column
/// of cells ORed with the columns' entries up to `reach` cells away along
/// the axis.
void dilate(const std::vector<std::uint8_t>& in, int ncx, int ncy, int reach,
            std::vector<std::uint8_t>& along_y, std::vector<std::uint8_t>& out)
{
  const auto ncells = static_cast<std::size_t>(ncx) * ncy;
  along_y.assign(ncells, 0);
  out.assign(ncells, 0);
  const std::uint8_t* from = in.data();
  std::uint8_t* mid = along_y.data();
  std::uint8_t* to = out.data();
#pragma omp parallel for schedule(static)
  for (int cx = 0; cx < ncx; ++cx)
  {
    const std::size_t column = static_cast<std::size_t>(cx) * ncy;
    for (int d = -reach; d <= reach; ++d)
    {
      const int first = std::max(0, -d), last = std::min(ncy, ncy - d);
      or_into(mid + column + first, from + column + first + d, last - first);
    }
  }
#pragma omp parallel for schedule(static)
  for (int cx = 0; cx < ncx; ++cx)
    for (int d = std::max(-reach, -cx); d <= std::min(reach, ncx - 1 - cx); ++d)
      or_into(to + static_cast<std::size_t>(cx) * ncy, mid + static_cast<std::size_t>(cx + d) * ncy,
              ncy);
}
} // namespace

template <class Stencil>
void DamageFields::open_nodes(const Particles& particles, const CellSort& sort, const Points& points)
{
  constexpr int K = Stencil::size;
  const std::size_t ngs = num_group_slots();
  _mass.assign(ngs, 0.0);
  _mass_damage.assign(ngs, 0.0);
  _group_full.assign(ngs, 0);
  _group_softening.assign(ngs, 0);
  _open_slot.resize(ngs);
  const std::array<const BSpline1D*, 2> basis{&_grid.basis(0), &_grid.basis(1)};
  const std::int32_t* order = sort.order().data();
  const std::int32_t* group = _group.data();
  const double* x = particles.x.data();
  const double* mass = particles.mass.data();
  const double* damage = _damage.data();
  const double* full = _full.data();
  const std::uint8_t* softening = _softening.data();
  const double* r1 = points.r1;
  const double* r2 = points.r2;
  // The sums of H&H eq. 21 over A and B together, with the terms P2G adds into
  // its md and full, cell by cell; strips of one parity share no node.
  list_cells(_near, _near_cells);
  for_each_listed_cell(
      _grid, *this, _groups, sort, _near_cells,
      [&](int cx, int cy, std::int64_t begin, std::int64_t end, const CellSlots& c)
      {
        double m[max_groups][K], md[max_groups][K];
        std::uint32_t any_full[max_groups], any_softening[max_groups];
        for (int f = 0; f < c.n; ++f) // the cell's groups only
        {
          std::fill_n(m[f], K, 0.0);
          std::fill_n(md[f], K, 0.0);
          any_full[f] = 0;
          any_softening[f] = 0;
        }
        const int cell[2] = {cx, cy};
        for (std::int64_t k = begin; k < end; ++k)
        {
          const std::int32_t p = order[k];
          Stencil s;
          if constexpr (Stencil::domains)
            s.evaluate(basis, cell, &x[2 * p], &r1[2 * p], &r2[2 * p]);
          else
            s.evaluate(basis, cell, &x[2 * p]);
          const int f = c.local(group[p]);
          const double mp = mass[p], Dp = damage[p];
          const bool failed = full[p] != 0.0, soft = softening[p] != 0;
          s.each_node(
              [&](int i, double w, const double*)
              {
                m[f][i] += w * mp;
                md[f][i] += w * mp * Dp;
                // Where its shape function is positive (CPDI: above round-off).
                const bool maps = Stencil::domains ? w > cpdi_maps_to : true;
                any_full[f] |= failed && maps ? 1u << i : 0u;
                any_softening[f] |= soft && maps ? 1u << i : 0u;
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

void DamageFields::open_cells(const Particles& particles, const CellSort& sort, const Points& points)
{
  // Cells within reach() cells of a fully damaged particle: only their
  // particles' stencils reach a node where one maps (the cells whose block
  // shares a node with a cell's are within reach() of it: the degree with
  // B-splines, up to 5 with CPDI's 4 x 4 blocks, which move inwards at the
  // grid's ends).
  dilate(_full_cell, _grid.cells()[0], _grid.cells()[1], _grid.block().reach(), _dilated_y, _near);
  // The open nodes, with the transfers' shape functions.
  if (points.r1) // CPDI: the points carry domains
    open_nodes<CpdiStencil<2>>(particles, sort, points);
  else if (_grid.degree() == 1)
    open_nodes<BSplineStencil<2, 1>>(particles, sort, points);
  else if (_grid.degree() == 2)
    open_nodes<BSplineStencil<2, 2>>(particles, sort, points);
  else
    open_nodes<BSplineStencil<2, 3>>(particles, sort, points);
}

void DamageFields::gradients(Particles& particles, const CellSort& sort)
{
  const int ncy = _grid.cells()[1];
  const std::int32_t* order = sort.order().data();
  const std::int64_t* start = sort.cell_start().data();
  {
    Stopwatch clock{_timers.neighbours};
    if (_neighbours.stale(_grid, sort, particles.x, _options.skin * _radius))
      _neighbours.build(_grid, sort, particles.x, (1.0 + 2.0 * _options.skin) * _radius);
  }
  Stopwatch clock{_timers.gradient};
  const double* x = particles.x.data();
  const double* damage = _damage.data();
  double* grad = particles.f64("damage_gradient").data();
  const NeighbourList& list = _neighbours;
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
  const BSpline1D& bx = _grid.basis(0);
  const BSpline1D& by = _grid.basis(1);
  // The kernel field's gradient at particle p into its column.
  std::uint8_t* set = _set.data();
  auto evaluate = [&](std::int32_t p)
  {
    const auto listed = list.of(p);
    const KernelValue<2> v = kernel_field<2>(p, listed.first, listed.size, x, damage, radius);
    grad[2 * p] = v.grad[0];
    grad[2 * p + 1] = v.grad[1];
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
      if (full[p] == 0.0 || grad[2 * p] != 0.0 || grad[2 * p + 1] != 0.0)
        continue;
      // A fully damaged particle without a gradient takes its side from its
      // nearest neighbour of the same body with one within r_p (sides()):
      // those of them outside the open cells need theirs too.
      for (const std::int32_t q : list.of(p))
      {
        const double dx = x[2 * q] - x[2 * p], dy = x[2 * q + 1] - x[2 * p + 1];
        if (body[q] != body[p] || dx * dx + dy * dy >= reach2)
          continue;
        const std::size_t cell = static_cast<std::size_t>(bx.cell(x[2 * q])) * ncy + by.cell(x[2 * q + 1]);
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

void DamageFields::sides(const Particles& particles, const CellSort& sort, const Points& points,
                         const double* grad)
{
  constexpr int K = CellSlots::K;
  const NodeBlock& block = _grid.block();
  const int width = block.width, nk = width * width;
  const int ncy = _grid.cells()[1];
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
  const double* domain_r1 = points.r1;
  const double* domain_r2 = points.r2;
  const std::uint32_t all = nk >= 32 ? ~0u : (1u << nk) - 1u;
  const std::array<const BSpline1D*, 2> basis{&_grid.basis(0), &_grid.basis(1)};
  auto reached = [&](std::int32_t p, int cx, int cy) -> std::uint32_t
  {
    if (!domain_r1)
      return all;
    CpdiStencil<2> stencil;
    const int cell[2] = {cx, cy};
    stencil.evaluate(basis, cell, &particles.x[2 * p], &domain_r1[2 * p], &domain_r2[2 * p]);
    std::uint32_t m = 0;
    for (int i = 0; i < CpdiStencil<2>::size; ++i)
      m |= stencil.n[i] > cpdi_maps_to ? 1u << i : 0u;
    return m;
  };
  // Algorithm 1, over the open cells (every cell whose block holds an open
  // node): per node and group, the particle gradient of largest magnitude,
  // ties to the smaller particle index. Each cell finds its own best per
  // node first (the largest, ties to the smaller index, is the same in any
  // order of comparison), then compares it with the node's. Strips of one
  // parity share no node, so the comparisons need no atomics.
  for_each_listed_cell(
      _grid, *this, _groups, sort, _open_cells,
      [&](int cx, int cy, std::int64_t begin, std::int64_t end, const CellSlots& c)
      {
        double norm[max_groups][K];
        std::int32_t best[max_groups][K];
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
          {
            norm[f][i] = 0.0;
            best[f][i] = -1;
          }
        for (std::int64_t k = begin; k < end; ++k)
        {
          const std::int32_t p = order[k];
          const double n2 = grad[2 * p] * grad[2 * p] + grad[2 * p + 1] * grad[2 * p + 1];
          if (n2 == 0.0)
            continue; // nothing to note
          const int f = c.local(group[p]);
          const std::uint32_t nodes = reached(p, cx, cy);
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
  const NeighbourList& list = _neighbours;
  // The nearest, the first in the list (the smallest index) among equals;
  // without a branch per neighbour (which of them qualify is unpredictable
  // inside a fragment).
  auto proxy = [&](std::int32_t p)
  {
    std::int32_t best = -1;
    double closest = reach2;
    const std::int32_t bp = body[p];
    const double xp = x[2 * p], yp = x[2 * p + 1];
    for (const std::int32_t q : list.of(p))
    {
      const double dx = x[2 * q] - xp, dy = x[2 * q + 1] - yp;
      const bool sloped = grad[2 * q] != 0.0 || grad[2 * q + 1] != 0.0;
      const double d2 = body[q] == bp && sloped ? dx * dx + dy * dy : reach2;
      best = d2 < closest ? q : best;
      closest = d2 < closest ? d2 : closest;
    }
    return best;
  };
  std::uint32_t* mask = _mask.data();
  std::uint8_t* set = _set.data();
  for_each_listed_cell(
      _grid, *this, _groups, sort, _open_cells,
      [&](int cx, int cy, std::int64_t begin, std::int64_t end, const CellSlots& c)
      {
        const std::size_t cell = static_cast<std::size_t>(cx) * ncy + cy;
        // Per group and node: G_i, and the position of its particle p*
        // (none: G_i = 0, and every pair chooses A); per group, whether
        // some node's G_i is not zero (else all its pairs choose A: the
        // sides below are +-0).
        double G[max_groups][K][2], star[max_groups][K][2];
        bool has_star[max_groups][K], live[max_groups] = {};
        std::uint32_t chose_b[max_groups] = {};
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
          {
            const std::int32_t s = c.slot[f][i], q = _best[s];
            const std::array<double, 2> Gi = nodal_gradient(s, grad);
            G[f][i][0] = Gi[0];
            G[f][i][1] = Gi[1];
            live[f] |= G[f][i][0] != 0.0 || G[f][i][1] != 0.0;
            has_star[f][i] = q >= 0;
            star[f][i][0] = q >= 0 ? x[2 * q] : 0.0;
            star[f][i][1] = q >= 0 ? x[2 * q + 1] : 0.0;
          }
        std::uint32_t any = 0;
        for (std::int64_t k = begin; k < end; ++k)
        {
          const std::int32_t p = order[k];
          const int f = c.local(group[p]);
          if (!live[f])
          {
            mask[p] = 0;
            continue;
          }
          const bool flat = grad[2 * p] == 0.0 && grad[2 * p + 1] == 0.0;
          const std::int32_t near = !flat ? p : full[p] != 0.0 ? proxy(p) : -1;
          std::uint32_t m = 0;
          if (near >= 0)
          {
            const double gx = grad[2 * near], gy = grad[2 * near + 1];
            for (int i = 0; i < nk; ++i)
            {
              const double side = gx * G[f][i][0] + gy * G[f][i][1];
              m |= side < 0.0 ? 1u << i : 0u;
            }
          }
          else if (full[p] == 0.0)
          {
            const double xp = x[2 * p], yp = x[2 * p + 1];
            for (int i = 0; i < nk; ++i)
            {
              const double side = has_star[f][i] ? (star[f][i][0] - xp) * G[f][i][0]
                                                       + (star[f][i][1] - yp) * G[f][i][1]
                                                 : 0.0;
              m |= side < 0.0 ? 1u << i : 0u;
            }
          }
          if (domain_r1)
            m &= reached(p, cx, cy); // no side at a node the particle does not map to
          mask[p] = m;
          set[p] |= m != 0u ? 1 : 0;
          chose_b[f] |= m;
          any |= m;
        }
        for (int f = 0; f < c.n; ++f)
          for (int i = 0; i < nk; ++i)
            if (chose_b[f] >> i & 1u)
              _has_b[c.slot[f][i]] = 1;
        _split[cell] = any != 0;
      });
}

void DamageFields::layout(const CellSort& sort, bool any_split)
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
  std::int32_t contact = 0;
  for (std::ptrdiff_t a = 0; a < na; ++a)
  {
    contact += _slot_start[a + 1] >= 2 ? 1 : 0;
    _slot_start[a + 1] += _slot_start[a];
  }
  _stats.nodes = contact;
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

std::vector<std::array<double, 4>> DamageFields::nodal_gradients(const Particles& particles) const
{
  std::vector<std::array<double, 4>> out;
  const std::int32_t na = _grid.num_active();
  const double* grad = particles.find("damage_gradient")->f64.data();
  for (std::int32_t a = 0; a < na; ++a)
  {
    const auto [g0, g1] = group_slots(a);
    for (std::int32_t g = g0; g < g1; ++g)
    {
      const std::array<double, 2> G =
          _dirty && static_cast<std::size_t>(g) < _best.size() ? nodal_gradient(g, grad)
                                                                : std::array<double, 2>{0.0, 0.0};
      out.push_back({static_cast<double>(_grid.active_nodes()[a]),
                     static_cast<double>(_groups ? _groups->field(g) : 0), G[0], G[1]});
    }
  }
  return out;
}

void DamageFields::clear(Particles& particles)
{
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  double* grad = particles.f64("damage_gradient").data();
  if (_clear_all || _mask.size() != particles.size())
  {
    _mask.assign(n, 0u);
    _set.assign(n, 0);
    std::fill(grad, grad + 2 * n, 0.0);
    _clear_all = false;
    return;
  }
  std::uint32_t* mask = _mask.data();
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
        grad[2 * p] = 0.0;
        grad[2 * p + 1] = 0.0;
        mask[p] = 0u;
        set[p] = 0;
      }
  }
}

void DamageFields::build(Particles& particles, const CellSort& sort, const Points& points)
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

} // namespace pfmpm
