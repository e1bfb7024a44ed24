// A vector written out in a test: V(0.5, -1.0) is the Vec (0.5, −1.0).
#pragma once

#include "core/model/model.hpp"

namespace hysid::testing {

template <class... T>
Vec V(T... entries) {
  Vec v(static_cast<Eigen::Index>(sizeof...(entries)));
  Eigen::Index i = 0;
  ((v[i++] = static_cast<double>(entries)), ...);
  return v;
}

}  // namespace hysid::testing
