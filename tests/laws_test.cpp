#include <gtest/gtest.h>
#include "qbond/laws.hpp"
TEST(Laws, Placeholder) { EXPECT_EQ(qbond::evaluate_law(qbond::Law::linear, 2, 1, 3, 0).T, 3.0); }
