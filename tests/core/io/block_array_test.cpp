// BlockArray: values appended across block boundaries come back in order, at their exact count.
#include <catch2/catch.hpp>

#include <cstdint>

#include "core/io/block_array.hpp"

namespace hysid {
namespace {

TEST_CASE("a BlockArray gives back what was appended, in order, across blocks", "[block_array]") {
  constexpr std::size_t kBlock = BlockArray<long>::kBlock;
  for (const std::size_t count : {std::size_t{0}, std::size_t{1}, kBlock - 1, kBlock, kBlock + 1, 2 * kBlock + 7}) {
    BlockArray<long> a;
    for (std::size_t i = 0; i < count; ++i) a.push_back(static_cast<long>(3 * i + 1));
    REQUIRE(a.size() == count);
    CHECK(a.empty() == (count == 0));
    if (count > 0) CHECK(a.back() == static_cast<long>(3 * (count - 1) + 1));
    if (count > kBlock) CHECK(a[kBlock] == static_cast<long>(3 * kBlock + 1));
    const std::vector<long> v = a.Take();
    REQUIRE(v.size() == count);
    CHECK(v.capacity() == count);
    bool in_order = true;
    for (std::size_t i = 0; i < count; ++i) in_order = in_order && v[i] == static_cast<long>(3 * i + 1);
    CHECK(in_order);
    CHECK(a.empty());  // handed over
    a.push_back(5);    // and usable again
    CHECK(a.size() == 1);
    CHECK(a.back() == 5);
  }
}

TEST_CASE("BlockArray::MoveTo fills a caller's array", "[block_array]") {
  BlockArray<std::uint8_t> a;
  const std::size_t count = BlockArray<std::uint8_t>::kBlock + 3;
  for (std::size_t i = 0; i < count; ++i) a.push_back(static_cast<std::uint8_t>(i % 251));
  std::vector<std::uint8_t> out(count + 1, 99);
  a.MoveTo(out.data());
  CHECK(out[0] == 0);
  CHECK(out[count - 1] == static_cast<std::uint8_t>((count - 1) % 251));
  CHECK(out[count] == 99);  // nothing written past the values
  CHECK(a.size() == 0);
}

}  // namespace
}  // namespace hysid
