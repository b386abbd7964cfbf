#include "ingest/rlds/example.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>

#include "core/error.h"
#include "proto/tf_example.pb.h"  // generated from ingest/proto/tf_example.proto

namespace wm::rlds {

struct Example::Impl {
  wm::tf::Example proto;
  const wm::tf::Feature& Get(const std::string& key, wm::tf::Feature::KindCase kind,
                             const char* kind_name) const {
    const auto& map = proto.features().feature();
    auto it = map.find(key);
    Check(it != map.end(), "feature key missing from tf.train.Example", {.key = key});
    if (it->second.kind_case() != kind) {
      throw Error(std::string("expected a ") + kind_name + " list", {.key = key});
    }
    return it->second;
  }
};

Example::Example(std::string_view bytes) : impl_(std::make_unique<Impl>()) {
  Check(impl_->proto.ParseFromArray(bytes.data(), static_cast<int>(bytes.size())),
        "record is not a valid serialized tf.train.Example");
}
Example::~Example() = default;
Example::Example(Example&&) noexcept = default;

bool Example::Has(const std::string& key) const {
  return impl_->proto.features().feature().count(key) > 0;
}

std::vector<std::string> Example::Keys() const {
  std::vector<std::string> keys;
  for (const auto& [k, v] : impl_->proto.features().feature()) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  return keys;
}

std::vector<std::string> Example::Bytes(const std::string& key) const {
  const auto& l = impl_->Get(key, wm::tf::Feature::kBytesList, "bytes").bytes_list().value();
  return {l.begin(), l.end()};
}
std::vector<float> Example::Floats(const std::string& key) const {
  const auto& l = impl_->Get(key, wm::tf::Feature::kFloatList, "float").float_list().value();
  return {l.begin(), l.end()};
}
std::vector<int64_t> Example::Int64s(const std::string& key) const {
  const auto& l = impl_->Get(key, wm::tf::Feature::kInt64List, "int64").int64_list().value();
  return {l.begin(), l.end()};
}

std::string Example::KindOf(const std::string& key) const {
  const auto& map = impl_->proto.features().feature();
  auto it = map.find(key);
  if (it == map.end()) return "missing";
  switch (it->second.kind_case()) {
    case wm::tf::Feature::kBytesList:
      return "bytes";
    case wm::tf::Feature::kFloatList:
      return "float";
    case wm::tf::Feature::kInt64List:
      return "int64";
    default:
      return "empty";
  }
}

size_t Example::Count(const std::string& key) const {
  const auto& map = impl_->proto.features().feature();
  auto it = map.find(key);
  if (it == map.end()) return 0;
  const auto& f = it->second;
  if (f.has_bytes_list()) return static_cast<size_t>(f.bytes_list().value_size());
  if (f.has_float_list()) return static_cast<size_t>(f.float_list().value_size());
  if (f.has_int64_list()) return static_cast<size_t>(f.int64_list().value_size());
  return 0;
}

struct ExampleBuilder::Impl {
  wm::tf::Example proto;
  wm::tf::Feature& Slot(const std::string& key) {
    return (*proto.mutable_features()->mutable_feature())[key];
  }
};

ExampleBuilder::ExampleBuilder() : impl_(std::make_unique<Impl>()) {}
ExampleBuilder::~ExampleBuilder() = default;

void ExampleBuilder::AddBytes(const std::string& key, const std::vector<std::string>& values) {
  auto* l = impl_->Slot(key).mutable_bytes_list();
  for (const auto& v : values) l->add_value(v);
}
void ExampleBuilder::AddFloats(const std::string& key, const std::vector<float>& values) {
  auto* l = impl_->Slot(key).mutable_float_list();
  for (float v : values) l->add_value(v);
}
void ExampleBuilder::AddInt64s(const std::string& key, const std::vector<int64_t>& values) {
  auto* l = impl_->Slot(key).mutable_int64_list();
  for (int64_t v : values) l->add_value(v);
}

std::string ExampleBuilder::Serialize() const {
  std::string out;
  {
    google::protobuf::io::StringOutputStream stream(&out);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    impl_->proto.SerializeToCodedStream(&coded);
  }
  return out;
}

}  // namespace wm::rlds
