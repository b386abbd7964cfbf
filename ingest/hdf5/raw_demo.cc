#include "ingest/hdf5/raw_demo.h"

#include "core/byte_fields.h"

namespace wm::ingest {
namespace {

// One field order for both directions.
template <class Demo, class F>
void VisitFields(Demo& d, F&& f) {
  f(d.num_steps);
  f(d.action_dim);
  f(d.actions);
  f(d.rewards);
  f(d.dones);
  f(d.camera);
  f(d.rgb);
  f(d.depth);
  f(d.height);
  f(d.width);
  f(d.depth_height);
  f(d.depth_width);
  f(d.language_instruction);
}

}  // namespace

std::string PackRawDemo(const RawDemo& demo) {
  std::string out;
  VisitFields(demo, [&](const auto& field) { bytes::Put(out, field); });
  return out;
}

RawDemo UnpackRawDemo(const std::string& packed) {
  RawDemo demo;
  bytes::Reader reader(packed);
  VisitFields(demo, [&](auto& field) { reader.Take(field); });
  Check(reader.done(), "packed demo has trailing bytes");
  return demo;
}

}  // namespace wm::ingest
