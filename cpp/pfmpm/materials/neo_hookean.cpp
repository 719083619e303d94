/// @file neo_hookean.cpp
/// @brief The neo-Hookean model: moduli, columns, and its registration with
/// the damage model chosen by name.
#include "pfmpm/materials/neo_hookean.h"

#include <sstream>
#include <stdexcept>

namespace pfmpm
{

namespace
{
void require(bool ok, const std::string& name, double value, const std::string& rule)
{
  if (!ok)
  {
    std::ostringstream msg;
    msg << name << " = " << value << ": " << rule;
    throw std::invalid_argument(msg.str());
  }
}

double positive(const Parameters& p, const std::string& key)
{
  const double value = p.number(key);
  require(std::isfinite(value) && value > 0.0, key, value, "must be > 0");
  return value;
}
} // namespace

template <class Damage>
NeoHookean<Damage>::NeoHookean(double E, double nu, double density, DeformationUpdate update,
                               Damage damage, double sigma_f)
    : _E(E), _nu(nu), _density(density), _update(update),
      _volume_as_g2p(update.scales_volume_as_g2p()), _damage(damage), _sigma_f(sigma_f)
{
  require(std::isfinite(E) && E > 0.0, "E", E, "must be > 0");
  require(std::isfinite(nu) && nu > -1.0 && nu < 0.5, "nu", nu, "must lie in (-1, 0.5)");
  require(std::isfinite(density) && density > 0.0, "density", density, "must be > 0");
  require(update.substeps >= 1, "substeps", update.substeps, "must be >= 1");
  if constexpr (damages)
    require(std::isfinite(sigma_f) && sigma_f > 0.0, "sigma_f", sigma_f, "must be > 0");
  _mu = E / (2.0 * (1.0 + nu));
  _lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

template <class Damage>
std::vector<ColumnSpec> NeoHookean<Damage>::columns() const
{
  std::vector<ColumnSpec> out{
      {"F", 4, DType::f64, {1.0, 0.0, 0.0, 1.0}, "deformation gradient F (H&H eq. 8)",
       "xx,xy,yx,yy", ""},
      {"J", 1, DType::f64, {1.0}, "J = det F, the volume ratio V / V_0", "", "J"}};
  if constexpr (damages)
  {
    out.push_back({"damage", 1, DType::f64, {0.0},
                   "damage D: 0 intact, 1 failed (H&H eqs. 23-24)", "", "damage"});
    out.push_back({"sigma_f", 1, DType::f64, {_sigma_f},
                   "tensile strength sigma_f (H&H eq. 25 with a Weibull field)", "", "sigma_f"});
    out.push_back({"dissipated", 1, DType::f64, {0.0},
                   "work dissipated by damage, the sum of V_0 W+ dD over the steps", "", ""});
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
/// "neo_hookean" with the damage model named by the word `damage`.
std::shared_ptr<Material> make_neo_hookean(const Parameters& p)
{
  const double E = positive(p, "E"), nu = p.number("nu"), density = p.number("density");
  const double substeps = p.number("substeps", 1.0);
  require(substeps >= 1.0 && substeps <= 1000.0 && substeps == std::floor(substeps), "substeps",
          substeps, "must be a whole number in [1, 1000]");
  const std::string integration = p.word("integration", "euler");
  if (integration != "euler" && integration != "exponential")
    throw std::invalid_argument("integration = " + integration + ": must be euler or exponential");
  const DeformationUpdate update{integration == "exponential", static_cast<int>(substeps)};
  require(!update.exponential || update.substeps == 1, "substeps", substeps,
          "must be 1 with integration = exponential (exact for the step's L)");
  const std::string damage = p.word("damage", "none");
  if (damage != "none" && damage != "rankine" && damage != "time_to_failure")
    throw std::invalid_argument("damage = " + damage
                                + ": must be none, rankine or time_to_failure");
  if (damage == "none")
    return std::make_shared<NeoHookean<NoDamage>>(E, nu, density, update, NoDamage{}, 0.0);
  const double sigma_f = positive(p, "sigma_f"), l_ch = positive(p, "l_ch");
  if (damage == "rankine")
  {
    const double Gf = positive(p, "Gf");
    const RankineSoftening rankine(E, Gf, l_ch);
    // H_s = Hbar l_ch / (1 - Hbar l_ch) needs Hbar l_ch < 1.
    require(rankine.a() * sigma_f * sigma_f < 1.0, "l_ch", l_ch,
            "must be < 2 E Gf / sigma_f^2 = " + std::to_string(2.0 * E * Gf / (sigma_f * sigma_f))
                + ", or the softening of H&H eq. 23 snaps back (H_s < 0)");
    return std::make_shared<NeoHookean<RankineSoftening>>(E, nu, density, update, rankine, sigma_f);
  }
  return std::make_shared<NeoHookean<TimeToFailure>>(E, nu, density, update,
                                                     TimeToFailure(positive(p, "c_f"), l_ch),
                                                     sigma_f);
}

const bool registered = MaterialRegistry::add("neo_hookean", make_neo_hookean);
} // namespace

} // namespace pfmpm
