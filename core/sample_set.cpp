// TEMPORARY placeholder: keeps the points, computes no hull (vertices() is empty). Replaced by the
// incremental CGAL hull being written on the `hull` branch; nothing may rely on it meanwhile.
#include "core/sample_set.hpp"
#include <vector>
namespace hysid {
struct SampleSet::Impl { int n; std::vector<Vec> pts; long version = 0; };
SampleSet::SampleSet(int d) : impl_(std::make_unique<Impl>()) { impl_->n = d; }
SampleSet::~SampleSet() = default;
SampleSet::SampleSet(SampleSet&&) noexcept = default;
SampleSet& SampleSet::operator=(SampleSet&&) noexcept = default;
void SampleSet::Add(ConstVecRef x) { impl_->pts.push_back(x); }
int SampleSet::dimension() const { return impl_->n; }
long SampleSet::size() const { return (long)impl_->pts.size(); }
int SampleSet::hull_dimension() const { return impl_->pts.empty() ? -1 : 2; }
Mat SampleSet::vertices() const { Mat m(impl_->n, 0); return m; }
bool SampleSet::Contains(ConstVecRef, double) const { return false; }
long SampleSet::version() const { return impl_->version; }
double SampleSet::Volume() const { return 0; }
Mat BatchHullVertices(const Mat& p) { return p; }
}
