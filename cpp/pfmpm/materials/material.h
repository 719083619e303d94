/// @file material.h
/// @brief Constitutive models behind one interface, found by name in a registry.
///
/// A model is one class deriving from MaterialModel<Self> plus one line,
/// PFMPM_REGISTER_MATERIAL(Self, "name"), in its own .cpp file. The class
/// declares its parameters (Self::parameters(), ParameterSpec: the scene
/// reader, its checks and the docs' tables come from them), the particle
/// columns it keeps (its state, Material::columns; a column that sums the
/// work the model dissipates says so, ColumnSpec::dissipation, and the energy
/// balance counts it) and per-particle functions; MaterialModel writes the
/// loops over a batch of particles once for every model. The step calls a
/// model once per batch (a cell's run of particles of one material), never
/// per particle.
#pragma once

#include "pfmpm/common/parameters.h"
#include "pfmpm/common/symmetric.h"
#include "pfmpm/particles/particles.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pfmpm
{

/// @brief The phase field's hold on a material (K&T eqs. 14-16, 20): its
/// tensile energy psi+ is degraded by g(c) = (1 - k_f) c^2 + k_f (K&T eq. 15), and
/// the history H = max(H, psi+) drives the phase field.
struct Degradation
{
  double k_f;             ///< residual stiffness
  const double* c;        ///< phase field per particle
  double* history;        ///< history field H per particle
  /// g(c) of K&T eq. 15.
  double g(double c_p) const { return (1.0 - k_f) * c_p * c_p + k_f; }
};

/// @brief Particles a model acts on at once: index[0, n), or, when index is
/// null, the contiguous range [first, first + n).
struct Batch
{
  const std::int32_t* index;
  std::size_t first;
  std::size_t n;
};

/// What a batch update reports for the checks of the step.
struct UpdateResult
{
  double wave = 0.0;        ///< largest P-wave speed in the batch after the update
  std::size_t bad = SIZE_MAX; ///< smallest particle with a non-finite state, or SIZE_MAX
};

/// @brief A constitutive model: its particle state and the stress it gives.
///
/// Kinematics: G2P hands each batch the velocity gradient L_p = sum_I v_I (x)
/// grad N_I (K&T eq. 78, H&H eq. 7), row-major Dim x Dim per particle (Dim the particles' directions); the model
/// advances its own kinematic measure with it (the small strain, or the
/// deformation gradient F <- (I + dt L) F) and computes the Cauchy stress.
/// A Material holds parameters only; bind() attaches it to a particle set,
/// finding its columns once, and the step works through that.
class Material
{
public:
  virtual ~Material() = default;
  /// The name the model is registered under.
  virtual std::string model() const = 0;
  /// The particle columns the model keeps, beyond the core arrays, for
  /// particles in `dim` directions (2 or 3).
  virtual std::vector<ColumnSpec> columns(int dim) const = 0;
  /// Whether the model runs in 3D too (else 2D alone: plane strain or stress).
  virtual bool solid() const = 0;
  /// Mass density.
  virtual double density() const = 0;
  /// P-wave speed of the undeformed material, sqrt((K + 4G/3) / rho).
  virtual double wave_speed() const = 0;
  /// Rayleigh wave speed of the undeformed material: the limit of a running crack's speed.
  virtual double rayleigh_speed() const = 0;

  /// @brief The model attached to a particle set (whose columns it has).
  class Bound
  {
  public:
    virtual ~Bound() = default;
    /// @brief Advance the batch's kinematic measure by dt with L (Dim x Dim per
    /// particle, in batch order) and set its stress; with `degradation`, the
    /// stress of K&T eq. 16 with g(c) and the history raised to psi+ (K&T eq. 20),
    /// and the stress only when `stress` is set: a cracking particle's stress
    /// is set again from the next phase field before a step reads it
    /// (Material::Bound::stress), so only the state an advance() leaves,
    /// which output reads, needs it.
    virtual UpdateResult update(const Batch& b, const double* L, double dt,
                                const Degradation* degradation, bool stress) const = 0;
    /// @brief Set the stress of the batch from its current state and phase
    /// field (after the phase-field solve changed c; K&T eqs. 14-16).
    virtual void stress(const Batch& b, const Degradation& degradation) const = 0;
    /// @brief Add V_p psi_p (K&T eq. 14: g psi+ + psi- with a degradation) of
    /// each particle of the batch to `sum`, in batch order.
    virtual void add_energy(const Batch& b, const Degradation* degradation, double& sum) const = 0;
    /// P-wave speed of particle p in its current state.
    virtual double wave_speed(std::size_t p) const = 0;
  };
  /// @brief Attach the model to `P`, which has its columns (for P.dim()).
  /// @throws std::invalid_argument for 3D particles and a 2D model.
  virtual std::unique_ptr<Bound> bind(Particles& P) const = 0;
};

/// @brief What the registry knows of a model: its description, its
/// parameters and how to build it from their checked values.
struct MaterialDeclaration
{
  std::string doc; ///< a sentence or two: the model, with its paper equations
  /// Whether a phase field can crack it (K&T eqs. 14-16: its energy splits
  /// into the part g(c) degrades and the rest); otherwise its `degraded` is
  /// never called.
  bool phase_field;
  std::vector<ParameterSpec> parameters;
  std::function<std::shared_ptr<Material>(const Parameters&)> make;
};

/// @brief The registry of constitutive models by name.
class MaterialRegistry
{
public:
  /// @brief Register `declaration` under `model` (at static initialisation).
  static bool add(const std::string& model, MaterialDeclaration declaration);
  /// @brief Build the model `model` from `given`, checked against its
  /// declared parameters (Parameters::checked).
  /// @throws std::invalid_argument for an unknown model, a missing or
  ///         unknown key, or a bad value.
  static std::shared_ptr<Material> make(const std::string& model, const Parameters& given);
  /// @brief The declaration of `model`.
  /// @throws std::invalid_argument for an unknown model.
  static const MaterialDeclaration& declaration(const std::string& model);
  /// The registered names, sorted.
  static std::vector<std::string> models();

private:
  static std::map<std::string, MaterialDeclaration>& table();
};

/// Register `Class`, which has `static const char* description`, `static
/// bool phase_field`, `static std::vector<ParameterSpec> parameters()` and a
/// constructor from Parameters, under the name `name`.
#define PFMPM_REGISTER_MATERIAL(Class, name)                                                      \
  namespace                                                                                     \
  {                                                                                             \
  const bool registered_##Class = ::pfmpm::MaterialRegistry::add(                               \
      name, {Class::description, Class::phase_field, Class::parameters(),                      \
             [](const ::pfmpm::Parameters& p) { return std::make_shared<Class>(p); }});        \
  }

/// @brief The P-wave speed of an isotropic elastic solid in plane strain,
/// sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu))) = sqrt((lambda + 2 mu) / rho),
/// in the order of operations that sets a scene's time step.
inline double plane_strain_wave_speed(double E, double nu, double density)
{
  return std::sqrt(E * (1.0 - nu) / (density * (1.0 + nu) * (1.0 - 2.0 * nu)));
}

/// @brief The P-wave speed of an isotropic elastic solid in plane stress,
/// sqrt(E / (rho (1 - nu^2))).
inline double plane_stress_wave_speed(double E, double nu, double density)
{
  return std::sqrt(E / (density * (1.0 - nu * nu)));
}

/// @brief The Rayleigh wave speed of an isotropic elastic solid by Viktorov's
/// approximation c_s (0.862 + 1.14 nu) / (1 + nu), c_s the shear wave speed.
inline double isotropic_rayleigh_speed(double E, double nu, double density)
{
  return std::sqrt(E / (2.0 * (1.0 + nu) * density)) * (0.862 + 1.14 * nu) / (1.0 + nu);
}

/// @brief The batch loops of Material, written once for every model.
///
/// `Model` provides, with Dim the directions of the particles (2, or 3
/// where `solid`):
/// - `static constexpr bool solid`: whether it runs in 3D;
/// - `struct View` with the pointers it needs and `View view(Particles&) const`;
/// - `template <int Dim> void advance(const View&, std::size_t p, const double* L,
///   double dt) const`, L the velocity gradient, row-major Dim x Dim;
/// - `template <int Dim> void undegraded(const View&, std::size_t p) const`,
///   the stress without a phase field (symmetric_size(Dim) entries);
/// - `template <int Dim> double energy(const View&, std::size_t p) const`, the
///   energy density per unit current volume;
/// - with a phase field: `template <int Dim> double degraded(const View&,
///   std::size_t p, double g) const`, the stress of K&T eq. 16 with g(c),
///   returning psi+, and `template <int Dim> void split(const View&,
///   std::size_t p, double& plus, double& minus) const`;
/// - `static constexpr bool constant_wave_speed` and, if false,
///   `template <int Dim> double state_wave_speed(const View&, std::size_t p) const`.
template <class Model>
class MaterialModel : public Material
{
public:
  bool solid() const final { return Model::solid; }

  std::unique_ptr<Bound> bind(Particles& P) const final
  {
    const Model& model = static_cast<const Model&>(*this);
    if (P.dim() == 3)
    {
      if constexpr (Model::solid)
        return std::make_unique<Attached<3>>(model, P);
      else
        throw std::invalid_argument("material model " + model.model()
                                    + " is two-dimensional (plane strain or plane stress)");
    }
    return std::make_unique<Attached<2>>(model, P);
  }

private:
  template <int Dim>
  class Attached final : public Bound
  {
  public:
    static constexpr int LL = Dim * Dim;          ///< entries of a velocity gradient
    static constexpr int T = symmetric_size(Dim); ///< entries of a stress

    Attached(const Model& model, Particles& P)
        : _model(model), _view(model.view(P)), _volume(P.volume.data()), _stress(P.stress.data())
    {
    }

    UpdateResult update(const Batch& b, const double* L, double dt,
                        const Degradation* degradation, bool stress) const override
    {
      UpdateResult r;
      if constexpr (Model::constant_wave_speed)
        r.wave = _model.wave_speed();
      each(b, [&](auto at)
           {
             if (degradation && stress)
             {
               for (std::size_t k = 0; k < b.n; ++k)
               {
                 const std::size_t p = at(k);
                 _model.template advance<Dim>(_view, p, &L[LL * k], dt);
                 // K&T eqs. 14-16 with this step's phase field; the history takes
                 // the largest tensile energy so far (K&T eq. 20, Kuhn-Tucker conditions).
                 const double plus =
                     _model.template degraded<Dim>(_view, p, degradation->g(degradation->c[p]));
                 degradation->history[p] = std::max(degradation->history[p], plus);
                 note(r, p, stress_sum(p) + degradation->history[p]);
               }
               return;
             }
             if (degradation)
             {
               for (std::size_t k = 0; k < b.n; ++k)
               {
                 const std::size_t p = at(k);
                 _model.template advance<Dim>(_view, p, &L[LL * k], dt);
                 // K&T eq. 20 as above, psi+ without the stress
                 double plus, minus;
                 _model.template split<Dim>(_view, p, plus, minus);
                 degradation->history[p] = std::max(degradation->history[p], plus);
                 note(r, p, plus + minus);
               }
               return;
             }
             for (std::size_t k = 0; k < b.n; ++k)
             {
               const std::size_t p = at(k);
               _model.template advance<Dim>(_view, p, &L[LL * k], dt);
               _model.template undegraded<Dim>(_view, p);
               note(r, p, stress_sum(p));
             }
           });
      return r;
    }

    void stress(const Batch& b, const Degradation& degradation) const override
    {
      each(b, [&](auto at)
           {
             for (std::size_t k = 0; k < b.n; ++k)
             {
               const std::size_t p = at(k);
               _model.template degraded<Dim>(_view, p, degradation.g(degradation.c[p]));
             }
           });
    }

    void add_energy(const Batch& b, const Degradation* degradation, double& sum) const override
    {
      each(b, [&](auto at)
           {
             for (std::size_t k = 0; k < b.n; ++k)
             {
               const std::size_t p = at(k);
               if (degradation)
               {
                 double plus, minus;
                 _model.template split<Dim>(_view, p, plus, minus);
                 // K&T eq. 14
                 sum += _volume[p] * (degradation->g(degradation->c[p]) * plus + minus);
                 continue;
               }
               sum += _volume[p] * _model.template energy<Dim>(_view, p);
             }
           });
    }

    double wave_speed(std::size_t p) const override
    {
      if constexpr (Model::constant_wave_speed)
        return _model.wave_speed();
      else
        return _model.template state_wave_speed<Dim>(_view, p);
    }

  private:
    /// The sum of particle p's stress components (finite when each is).
    double stress_sum(std::size_t p) const
    {
      const double* sig = &_stress[T * p];
      double sum = sig[0];
      for (int k = 1; k < T; ++k)
        sum += sig[k];
      return sum;
    }
    /// The checks of particle p after its update: `state`, a sum of its new
    /// state's numbers, is finite, and its wave speed when that follows the
    /// state.
    void note(UpdateResult& r, std::size_t p, double state) const
    {
      if (!std::isfinite(state))
        r.bad = std::min(r.bad, p);
      if constexpr (!Model::constant_wave_speed)
        r.wave = std::max(r.wave, _model.template state_wave_speed<Dim>(_view, p));
    }
    /// f(at) with at(k) the k-th particle of the batch, listed or contiguous.
    template <class F>
    static void each(const Batch& b, F&& f)
    {
      if (b.index)
        f([idx = b.index](std::size_t k) { return static_cast<std::size_t>(idx[k]); });
      else
        f([first = b.first](std::size_t k) { return first + k; });
    }

    const Model& _model;
    typename Model::View _view;
    const double* _volume;
    const double* _stress;
  };
};

/// @brief Call f(material, batch) for each run of consecutive entries of
/// order[begin, end) that share a material.
template <class F>
void for_each_material_run(const std::int32_t* material, const std::int32_t* order,
                           std::int64_t begin, std::int64_t end, F&& f)
{
  while (begin < end)
  {
    const std::int32_t m = material[order[begin]];
    std::int64_t stop = begin + 1;
    while (stop < end && material[order[stop]] == m)
      ++stop;
    f(m, Batch{order + begin, 0, static_cast<std::size_t>(stop - begin)});
    begin = stop;
  }
}

} // namespace pfmpm
