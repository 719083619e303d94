/// @file particles.h
/// @brief Material point storage: the core arrays every run has, and named
/// columns for the state that the models of a scene add.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <string_view>
#include <vector>

namespace pfmpm
{

/// Element type of a particle column.
enum class DType : int
{
  f64 = 0, ///< double
  i32 = 1, ///< std::int32_t
  i64 = 2  ///< std::int64_t: the particles' ids (a core array; no named column has it)
};

/// @brief Declaration of a particle column: N rows of `components` values.
struct ColumnSpec
{
  std::string name;    ///< the key by which the column is found (bindings, checkpoints)
  int components = 1;  ///< values per particle
  DType dtype = DType::f64;
  /// Initial value of a row: one value for every component, or one per
  /// component (the identity (1, 0, 0, 1) of a deformation gradient).
  std::vector<double> fill{0.0};
  std::string doc;     ///< one line: what it holds, with its paper equation
  /// Names of the components, comma-separated ("x,y"; "xx,yy,xy,zz" for a
  /// plane tensor with its out-of-plane entry); empty for one component.
  std::string layout;
  /// Name of the field in the particle output (VTU), or empty when the column
  /// is not written there.
  std::string output;
  /// For a column that sums the work its model has dissipated per particle
  /// since t = 0: the kind of dissipation ("damage", "plastic"). The energies
  /// report its sum over the particles as `<kind>_dissipation`, a term of the
  /// energy balance. Empty for other columns.
  std::string dissipation = {};
};

/// @brief A column's declaration and its storage (row-major N x components).
struct Column
{
  ColumnSpec spec;
  std::vector<double> f64;       ///< storage when spec.dtype is f64
  std::vector<std::int32_t> i32; ///< storage when spec.dtype is i32

  void* data() { return spec.dtype == DType::f64 ? static_cast<void*>(f64.data()) : i32.data(); }
  std::size_t values() const { return spec.dtype == DType::f64 ? f64.size() : i32.size(); }
};

/// @brief Material points as contiguous arrays, row-major (N x k) where a
/// quantity has k components.
///
/// The core arrays are members: x, v, fext (N x Dim, Dim = dim() the
/// directions, 2 or 3); stress (the Cauchy stress, N x symmetric_size(Dim):
/// xx, yy, xy, zz, and in 3D yz, xz; common/symmetric.h); mass, volume (N);
/// body and material indices (N, int32); id (N, int64), the particle's
/// global id. Everything else a scene's models keep per particle (the
/// small strain of a linear elastic material, the phase field c and history H,
/// ...) is a named column, added by the model that needs it
/// (Material::columns, PhaseField::columns) and found by name. columns()
/// lists both kinds in one order, which is what the bindings, checkpoints and
/// particle output iterate over.
class Particles
{
public:
  /// @brief n particles in `dim` directions (2 or 3) at rest, zero mass,
  /// volume, stress and force, with the ids 0 to n - 1.
  /// @throws std::invalid_argument for another dim.
  explicit Particles(std::size_t n, int dim = 2);

  std::size_t size() const { return mass.size(); }

  /// @brief n rows in every array and column: the first rows kept, new rows
  /// zero (ids included). A process that receives particles from another
  /// (a migration) resizes, then writes every column of its rows.
  void resize(std::size_t n);
  /// The directions: 2 or 3 coordinates per position.
  int dim() const { return _dim; }

  std::vector<double> x;      ///< position
  std::vector<double> v;      ///< velocity
  std::vector<double> mass;   ///< mass M_p
  std::vector<double> volume; ///< current volume V_p
  std::vector<double> stress; ///< Cauchy stress (xx, yy, xy, zz[, yz, xz])
  std::vector<double> fext;   ///< external force: body force and traction (K&T eq. 42)
  std::vector<std::int32_t> body;     ///< body (velocity field or contact group) index
  std::vector<std::int32_t> material; ///< material index
  /// Global id: a function of where the particle was seeded (its body and
  /// its place in the body's seeding lattice), not of its place in these
  /// arrays, which a process seeding part of a scene, or a migration of
  /// particles between processes, changes. The arrays are kept in ascending
  /// id order (check_order()), so that every order and tie-break the core
  /// keys on the particle index, the stable cell sort's order within a cell
  /// and "the smaller index" of DamageFields, is keyed on the id.
  std::vector<std::int64_t> id;

  /// @brief Check that the ids ascend (strictly: they are unique).
  /// @throws std::invalid_argument naming the first particle out of order,
  ///         its id and the id before it.
  void check_order() const;

  /// @brief Add a column, every row `spec.fill`; if one of that name exists
  /// with the same shape and type, keep it (its values included).
  /// @throws std::invalid_argument if the name is a core array's or is taken
  ///         by a column of another shape or type, or for the type int64.
  Column& add(const ColumnSpec& spec);
  /// The column `name`, or nullptr.
  Column* find(std::string_view name);
  const Column* find(std::string_view name) const;
  /// @brief The values of the f64 column `name`.
  /// @throws std::out_of_range naming the column if there is none of that type.
  std::vector<double>& f64(std::string_view name);
  const std::vector<double>& f64(std::string_view name) const;
  /// @brief The values of the int32 column `name`.
  std::vector<std::int32_t>& i32(std::string_view name);

  /// One entry of columns(): a core array or a named column.
  struct Entry
  {
    const ColumnSpec* spec;
    void* data;
    std::size_t values;
  };
  /// @brief Every array, core ones first (x, v, mass, volume, stress, fext,
  /// body, material, id), then the named columns in the order they were added.
  std::vector<Entry> columns();

private:
  std::deque<Column> _columns; // a deque: adding one moves no other
  int _dim;
};

} // namespace pfmpm
