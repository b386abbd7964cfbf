#include "metrics/segmentation/seg_config.h"

#include <yaml-cpp/yaml.h>

#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"

namespace wm::metrics::seg {
namespace {

// The one list of each section's scalar fields, shared by the reader and its unknown-key check.
template <class F>
void VisitMotion(MotionMaskOptions& m, F&& f) {
  f("change_threshold", m.change_threshold);
  f("min_mode_frames", m.min_mode_frames);
  f("static_margin", m.static_margin);
  f("shadows", m.shadows);
  f("shadow_ratio", m.shadow_ratio);
  f("shadow_ratio_tolerance", m.shadow_ratio_tolerance);
  f("shadow_max_distortion", m.shadow_max_distortion);
  f("open_radius", m.open_radius);
  f("close_radius", m.close_radius);
  f("min_part_fraction", m.min_part_fraction);
}

template <class F>
void VisitDepth(DepthMaskOptions& d, F&& f) {
  f("depth_scale", d.depth_scale);
  f("plane_distance", d.plane_distance);
  f("plane_iterations", d.plane_iterations);
  f("cluster_tolerance", d.cluster_tolerance);
  f("min_cluster_points", d.min_cluster_points);
}

// "section.key", as errors name a key.
std::string Dotted(const std::string& section, const std::string& key) {
  return section + "." + key;
}

template <class T>
T ReadScalar(const YAML::Node& v, const std::string& file, const std::string& key) {
  try {
    Check(v.IsScalar(), "expected a scalar", {.file = file, .key = key});
    return v.as<T>();
  } catch (const YAML::Exception&) {
    throw Error("cannot read '" + v.Scalar() + "' as " +
                    (std::is_same_v<T, bool>       ? "a boolean"
                     : std::is_integral_v<T>       ? "an integer"
                     : std::is_floating_point_v<T> ? "a number"
                                                   : "a string"),
                {.file = file, .key = key});
  }
}

// Reads section `name` (a mapping of scalars) through `visit`, rejecting keys it does not know
// and the names in `extra`, which the caller reads itself.
template <class Options, class Visit>
void ReadSection(const YAML::Node& root, const std::string& name, Options& options, Visit visit,
                 const std::set<std::string>& extra, const std::string& file) {
  const YAML::Node section = root[name];
  if (!section) return;
  Check(section.IsMap(), "expected a mapping", {.file = file, .key = name});
  std::set<std::string> known = extra;
  visit(options, [&](const char* key, auto& field) {
    known.insert(key);
    if (const YAML::Node v = section[key]) {
      field = ReadScalar<std::decay_t<decltype(field)>>(v, file, Dotted(name, key));
    }
  });
  CheckKnownYamlKeys(section, known, file, name, "see docs/metrics-segmentation.md");
}

LabelMap ReadLabels(const YAML::Node& root, const std::string& file) {
  LabelMap map;
  if (const YAML::Node labels = root["labels"]) {
    Check(labels.IsMap(), "expected a mapping of label value -> region",
          {.file = file, .key = "labels"});
    for (const auto& kv : labels) {
      const std::string key = "labels." + kv.first.Scalar();
      const int label = ReadScalar<int>(kv.first, file, key);
      try {
        map.regions[label] = ParseRegion(ReadScalar<std::string>(kv.second, file, key));
      } catch (const Error& e) {
        throw e.WithFile(file).WithKey(key);
      }
    }
  }
  if (const YAML::Node unlisted = root["unlisted"]) {
    const std::string name = ReadScalar<std::string>(unlisted, file, "unlisted");
    if (name != "error") {
      try {
        map.unlisted = ParseRegion(name);
      } catch (const Error& e) {
        throw Error(e.message() + " (or error)", {.file = file, .key = "unlisted"});
      }
    }
  }
  return map;
}

CameraIntrinsics ReadIntrinsics(const YAML::Node& v, const std::string& file) {
  const std::string key = "depth.intrinsics";
  Check(v.IsSequence() && v.size() == 4, "expected [fx, fy, cx, cy] in pixels",
        {.file = file, .key = key});
  std::string text;
  for (size_t i = 0; i < 4; ++i) {
    text += (i ? "," : "") + std::to_string(ReadScalar<double>(v[i], file, key));
  }
  try {
    return CameraIntrinsics::Parse(text);
  } catch (const Error& e) {
    throw Error(e.message(), {.file = file, .key = key});
  }
}

}  // namespace

SegConfig ParseSegConfig(const std::string& yaml_text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error("invalid YAML: " + std::string(e.what()), {.file = file});
  }
  SegConfig config;
  if (root.IsNull()) return config;
  Check(root.IsMap(), "expected a mapping at the top level", {.file = file});
  CheckKnownYamlKeys(root, {"labels", "unlisted", "arm_borders", "motion", "depth"}, file, "",
                     "expected labels, unlisted, arm_borders, motion or depth");
  config.labels = ReadLabels(root, file);
  if (const YAML::Node borders = root["arm_borders"]) {
    try {
      config.motion.arm_borders =
          ArmBorders::Parse(ReadScalar<std::string>(borders, file, "arm_borders"));
    } catch (const Error& e) {
      throw e.WithFile(file);
    }
    config.depth.arm_borders = config.motion.arm_borders;
  }
  ReadSection(
      root, "motion", config.motion, [](MotionMaskOptions& m, auto&& f) { VisitMotion(m, f); }, {},
      file);
  ReadSection(
      root, "depth", config.depth, [](DepthMaskOptions& d, auto&& f) { VisitDepth(d, f); },
      {"intrinsics"}, file);
  // YAML::Node() is a defined null node, so test for the key instead of the node's truth.
  if (root["depth"] && root["depth"]["intrinsics"]) {
    config.depth.intrinsics = ReadIntrinsics(root["depth"]["intrinsics"], file);
  }
  try {
    config.motion.Check();
    DepthMaskOptions depth = config.depth;
    if (!depth.intrinsics) depth.intrinsics = CameraIntrinsics{1, 1, 0, 0};  // may come later
    depth.Check();
  } catch (const Error& e) {
    throw e.WithFile(file);
  }
  return config;
}

SegConfig LoadSegConfig(const std::string& path) { return ParseSegConfig(ReadFile(path), path); }

LabelMap ParseLabelList(const std::string& text) {
  LabelMap map;
  std::stringstream in(text);
  for (std::string pair; std::getline(in, pair, ',');) {
    const size_t eq = pair.find('=');
    size_t used = 0;
    int label = 0;
    try {
      label = std::stoi(pair.substr(0, eq), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    Check(eq != std::string::npos && used == eq,
          "expected label=region pairs such as 0=background,1=arm,2=object, got '" + pair + "'",
          {.key = "--labels"});
    try {
      map.regions[label] = ParseRegion(pair.substr(eq + 1));
    } catch (const Error& e) {
      throw e.WithKey("--labels");
    }
  }
  map.Check();
  return map;
}

}  // namespace wm::metrics::seg
