/// @file test_particles.cpp
/// @brief The particle store's ids: 0 to n - 1 by default, an int64 core
/// column, and the ascending order that the core checks.
#include "pfmpm/particles/particles.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

using namespace pfmpm;

namespace
{
/// The message of the std::invalid_argument that `f` throws, or "" if none.
template <class F>
std::string refusal(F&& f)
{
  try
  {
    f();
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  return "";
}
} // namespace

TEST(Particles, IdsAreTheIndexByDefault)
{
  for (int dim : {2, 3})
  {
    const Particles P(5, dim);
    EXPECT_EQ(P.id, (std::vector<std::int64_t>{0, 1, 2, 3, 4}));
    EXPECT_NO_THROW(P.check_order());
  }
}

TEST(Particles, IdIsAnInt64CoreColumnWrittenToTheOutput)
{
  Particles P(3, 3);
  P.id = {7, 40, 41};
  const std::vector<Particles::Entry> columns = P.columns();
  ASSERT_EQ(columns.size(), 9u); // the core arrays alone
  const Particles::Entry& id = columns[8];
  EXPECT_EQ(id.spec->name, "id");
  EXPECT_EQ(id.spec->dtype, DType::i64);
  EXPECT_EQ(id.spec->output, "id");
  EXPECT_EQ(id.values, 3u);
  EXPECT_EQ(static_cast<const std::int64_t*>(id.data)[1], 40);
}

TEST(Particles, ResizeKeepsTheFirstRowsAndZeroesNewOnes)
{
  Particles p(3, 3);
  p.add({"c", 1, DType::f64, {1.0}, "phase field", "", ""});
  p.add({"held_by", 1, DType::i32, {0.0}, "regions", "", ""});
  p.x[3] = 7.0;
  p.f64("c")[1] = 0.5;
  p.i32("held_by")[2] = 4;
  p.resize(5);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_EQ(p.x.size(), 15u);
  EXPECT_EQ(p.stress.size(), 30u);
  EXPECT_EQ(p.x[3], 7.0);
  EXPECT_EQ(p.f64("c"), (std::vector<double>{1.0, 0.5, 1.0, 0.0, 0.0}));
  EXPECT_EQ(p.i32("held_by"), (std::vector<std::int32_t>{0, 0, 4, 0, 0}));
  EXPECT_EQ(p.id, (std::vector<std::int64_t>{0, 1, 2, 0, 0}));
  p.resize(2);
  EXPECT_EQ(p.f64("c"), (std::vector<double>{1.0, 0.5}));
  EXPECT_EQ(p.v.size(), 6u);
}

TEST(Particles, OrderCheckNamesTheFirstParticleOutOfOrder)
{
  Particles P(4);
  P.id = {3, 8, 8, 2};
  EXPECT_EQ(refusal([&] { P.check_order(); }),
            "particle 2: id 8 after id 8 (the particles must be in ascending id order)");
  P.id = {3, 8, 9, 2};
  EXPECT_EQ(refusal([&] { P.check_order(); }),
            "particle 3: id 2 after id 9 (the particles must be in ascending id order)");
  P.id = {-5, 0, 1ll << 40, (1ll << 40) + 1}; // sparse ids
  EXPECT_NO_THROW(P.check_order());
}

TEST(Particles, NamedColumnsHaveNoInt64)
{
  Particles P(2);
  EXPECT_EQ(refusal([&] { P.add({"tag", 1, DType::i64, {0.0}, "", "", ""}); }),
            "particle column tag: int64 is the ids' type, not a column's");
}
