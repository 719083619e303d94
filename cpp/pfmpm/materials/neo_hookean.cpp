/// @file neo_hookean.cpp
/// @brief The neo-Hookean model: moduli, columns, and its registration with
/// the damage model chosen by name.
#include "pfmpm/materials/neo_hookean.h"

#include <algorithm>
#include <map>
#include <sstream>
#include <stdexcept>

namespace pfmpm
{

namespace
{
/// The parameters of "neo_hookean", its damage models' with them.
std::vector<ParameterSpec> neo_hookean_parameters()
{
  using P = ParameterSpec;
  return {P::number("E", "stress", "Young's modulus of the small-strain limit").above(0.0),
          P::number("nu", "1", "Poisson's ratio").above(-1.0).below(0.5),
          P::number("density", "density", "reference mass density").above(0.0),
          P::word("integration", {"euler", "exponential"},
                  "how F follows the velocity gradient: H&H eq. 8, F <- (I + dt L) F, or its "
                  "exponential F <- exp(dt L) F, exact for the step's L")
              .fallback("euler"),
          P::integer("substeps", "sub-steps of H&H eq. 8 per step (1 with exponential)")
              .at_least(1.0)
              .at_most(1000.0)
              .fallback(1.0),
          P::word("plane", {"strain"}, "the 2D kinematic assumption: plane strain only (F_33 = 1)")
              .fallback("strain")
              .from("plane"),
          P::word("damage", {"none", "rankine", "time_to_failure"},
                  "the damage model: Rankine softening (H&H eq. 23) or time to failure "
                  "(H&H eq. 24)")
              .fallback("none")
              .from("damage.model"),
          P::number("sigma_f", "stress", "tensile strength (H&H eqs. 23-24)")
              .above(0.0)
              .when_needed()
              .from("damage.sigma_f"),
          P::number("Gf", "energy/area", "fracture energy of Rankine softening (H&H eq. 23)")
              .above(0.0)
              .when_needed()
              .from("damage.Gf"),
          P::number("c_f", "speed", "crack speed of time-to-failure damage (H&H eq. 24)")
              .above(0.0)
              .when_needed()
              .from("damage.c_f"),
          P::number("l_ch", "length", "the length damage softens over (H&H eqs. 23-24)")
              .above(0.0)
              .when_needed()
              .from("damage.l_ch")};
}

/// Refuse the damage parameters that damage = `damage` does not read.
void refuse_unused(const Parameters& p, const std::string& damage)
{
  const std::map<std::string, std::vector<std::string>> reads{
      {"none", {}}, {"rankine", {"sigma_f", "Gf", "l_ch"}}, {"time_to_failure", {"sigma_f", "c_f", "l_ch"}}};
  for (const char* key : {"sigma_f", "Gf", "c_f", "l_ch"})
  {
    const auto& used = reads.at(damage);
    if (p.has(key) && std::find(used.begin(), used.end(), key) == used.end())
      throw std::invalid_argument(std::string(key) + ": not a parameter of the neo_hookean model with damage = "
                                  + damage);
  }
}

/// The number `key`, which damage = `damage` needs.
double needed(const Parameters& p, const std::string& key, const std::string& damage)
{
  if (!p.has(key))
    throw std::invalid_argument(key + ": missing (damage = " + damage + " needs it)");
  return p.number(key);
}
} // namespace

template <class Damage>
NeoHookean<Damage>::NeoHookean(double E, double nu, double density, DeformationUpdate update,
                               Damage damage, double sigma_f)
    : _E(E), _nu(nu), _density(density), _update(update),
      _volume_as_g2p(update.scales_volume_as_g2p()), _damage(damage), _sigma_f(sigma_f)
{
  const auto specs = neo_hookean_parameters();
  declared(specs, "E").check(E);
  declared(specs, "nu").check(nu);
  declared(specs, "density").check(density);
  declared(specs, "substeps").check(update.substeps);
  if constexpr (damages)
    declared(specs, "sigma_f").check(sigma_f);
  _mu = E / (2.0 * (1.0 + nu));
  _lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

template <class Damage>
std::vector<ColumnSpec> NeoHookean<Damage>::columns(int dim) const
{
  std::vector<ColumnSpec> out;
  if (dim == 3)
    out.push_back({"F", 9, DType::f64, {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0},
                   "deformation gradient F (H&H eq. 8)", "xx,xy,xz,yx,yy,yz,zx,zy,zz", ""});
  else
    out.push_back({"F", 4, DType::f64, {1.0, 0.0, 0.0, 1.0}, "deformation gradient F (H&H eq. 8)",
                   "xx,xy,yx,yy", ""});
  out.push_back({"J", 1, DType::f64, {1.0}, "J = det F, the volume ratio V / V_0", "", "J"});
  if constexpr (damages)
  {
    out.push_back({"damage", 1, DType::f64, {0.0},
                   "damage D: 0 intact, 1 failed (H&H eqs. 23-24)", "", "damage"});
    out.push_back({"sigma_f", 1, DType::f64, {_sigma_f},
                   "tensile strength sigma_f (H&H eq. 25 with a Weibull field)", "", "sigma_f"});
    out.push_back({"dissipated", 1, DType::f64, {0.0},
                   "work dissipated by damage, the sum of V_0 W+ dD over the steps", "", "",
                   "damage"});
    out.push_back({"softening", 1, DType::i32, {0.0},
                   "1 where the damage grew in the last step (on the softening branch of "
                   "H&H eq. 23 or 24), 0 where it held",
                   "", ""});
  }
  return out;
}

template <class Damage>
typename NeoHookean<Damage>::View NeoHookean<Damage>::view(Particles& P) const
{
  View v{P.f64("F").data(), P.f64("J").data(), P.stress.data(), P.volume.data(),
         nullptr, nullptr, nullptr, nullptr};
  if constexpr (damages)
  {
    v.damage = P.f64("damage").data();
    v.sigma_f = P.f64("sigma_f").data();
    v.dissipated = P.f64("dissipated").data();
    v.softening = P.i32("softening").data();
  }
  return v;
}

template class NeoHookean<NoDamage>;
template class NeoHookean<RankineSoftening>;
template class NeoHookean<TimeToFailure>;

namespace
{
/// "neo_hookean" with the damage model named by the word `damage`, from
/// checked parameters.
std::shared_ptr<Material> make_neo_hookean(const Parameters& p)
{
  const double E = p.number("E"), nu = p.number("nu"), density = p.number("density");
  const DeformationUpdate update{p.word("integration") == "exponential",
                                 static_cast<int>(p.number("substeps"))};
  if (update.exponential && update.substeps != 1)
    throw std::invalid_argument(refusal("substeps", update.substeps,
                                        "must be 1 with integration = exponential (exact for the step's L)"));
  const std::string& damage = p.word("damage");
  refuse_unused(p, damage);
  if (damage == "none")
    return std::make_shared<NeoHookean<NoDamage>>(E, nu, density, update, NoDamage{}, 0.0);
  const double sigma_f = needed(p, "sigma_f", damage), l_ch = needed(p, "l_ch", damage);
  if (damage == "rankine")
  {
    const double Gf = needed(p, "Gf", damage);
    const RankineSoftening rankine(E, Gf, l_ch);
    // H_s = Hbar l_ch / (1 - Hbar l_ch) needs Hbar l_ch < 1.
    if (rankine.a() * sigma_f * sigma_f >= 1.0)
      throw std::invalid_argument(refusal(
          "l_ch", l_ch,
          "must be < 2 E Gf / sigma_f^2 = " + std::to_string(2.0 * E * Gf / (sigma_f * sigma_f))
              + ", or the softening of H&H eq. 23 snaps back (H_s < 0)"));
    return std::make_shared<NeoHookean<RankineSoftening>>(E, nu, density, update, rankine, sigma_f);
  }
  return std::make_shared<NeoHookean<TimeToFailure>>(
      E, nu, density, update, TimeToFailure(needed(p, "c_f", damage), l_ch), sigma_f);
}

const bool registered = MaterialRegistry::add(
    "neo_hookean",
    {"Compressible neo-Hookean elasticity in plane strain (H&H eq. 22) on the deformation "
     "gradient (H&H eq. 8), with optional Rankine or time-to-failure damage (H&H eqs. 23-27).",
     false, neo_hookean_parameters(), make_neo_hookean});
} // namespace

} // namespace pfmpm
