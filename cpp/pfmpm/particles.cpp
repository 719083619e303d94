#include "particles.h"

namespace pfmpm
{

Particles::Particles(std::size_t n)
    : x(2 * n, 0.0), v(2 * n, 0.0), mass(n, 0.0), volume(n, 0.0), strain(3 * n, 0.0),
      stress(4 * n, 0.0), fext(2 * n, 0.0), body(n, 0), material(n, 0), c(n, 1.0),
      history(n, 0.0), phi(n, 0.0)
{
}

} // namespace pfmpm
