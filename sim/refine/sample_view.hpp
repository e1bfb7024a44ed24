// A read-only view of r × K samples held elsewhere, columns contiguous (a column range of a Mat), as
// a refinement chain holds its samples (sim/refine/refine.hpp: RefineChain::y and u) without copying
// them. Assigning a view to another rebinds it (an Eigen::Map would copy the values instead), so a
// struct holding views copies and assigns as a value.
#pragma once

#include <new>

#include "core/model/model.hpp"

namespace hysid {

class SampleView : public Eigen::Map<const Mat> {
 public:
  using Base = Eigen::Map<const Mat>;
  SampleView() : Base(nullptr, 0, 0) {}
  SampleView(const double* data, Eigen::Index rows, Eigen::Index cols) : Base(data, rows, cols) {}
  // Columns [first, first + count) of m; m must outlive the view.
  SampleView(const Mat& m, Eigen::Index first, Eigen::Index count)
      : Base(m.data() + m.rows() * first, m.rows(), count) {}
  // All of m; m must outlive the view.
  explicit SampleView(const Mat& m) : SampleView(m, 0, m.cols()) {}
  SampleView(Mat&&, Eigen::Index, Eigen::Index) = delete;  // (would view a temporary)
  explicit SampleView(Mat&&) = delete;
  SampleView(const SampleView& other) : Base(other.data(), other.rows(), other.cols()) {}
  SampleView& operator=(const SampleView& other) {
    // Eigen's documented way to point a Map elsewhere: construct it again in place.
    new (static_cast<Base*>(this)) Base(other.data(), other.rows(), other.cols());
    return *this;
  }
  ~SampleView() = default;
};

}  // namespace hysid
