// Values appended one at a time into blocks of a fixed size, for arrays whose length is known only
// at the end (the samples of a CSV read row by row, core/io/sample_data.cpp). Growing never copies
// what is held and leaves at most one block unused, where a std::vector that doubles holds room for
// up to twice its values, and three times while it reallocates. MoveTo hands the values over block
// by block, freeing each block once it is copied: while an array is moved, the part of the
// destination written and the blocks not yet copied hold its values about once.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

namespace hysid {

template <class T>
class BlockArray {
 public:
  static constexpr std::size_t kBlock = std::size_t{1} << 16;  // values per block

  void push_back(T value) {
    if (size_ % kBlock == 0) blocks_.push_back(std::make_unique_for_overwrite<T[]>(kBlock));
    blocks_.back()[size_ % kBlock] = value;
    ++size_;
  }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const T& back() const { return blocks_.back()[(size_ - 1) % kBlock]; }
  const T& operator[](std::size_t i) const { return blocks_[i / kBlock][i % kBlock]; }

  // The values into out[0, size()) in order, each block freed once copied; empty afterwards.
  void MoveTo(T* out) {
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      std::copy_n(blocks_[b].get(), std::min(kBlock, size_ - b * kBlock), out + b * kBlock);
      blocks_[b].reset();
    }
    blocks_.clear();
    size_ = 0;
  }
  // The values as a vector of their exact size (MoveTo).
  std::vector<T> Take() {
    std::vector<T> values(size_);
    MoveTo(values.data());
    return values;
  }

 private:
  std::vector<std::unique_ptr<T[]>> blocks_;
  std::size_t size_ = 0;
};

}  // namespace hysid
