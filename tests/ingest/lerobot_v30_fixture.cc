#include "tests/ingest/lerobot_v30_fixture.h"

extern "C" {
#include <libavformat/avformat.h>
}

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "ingest/lerobot/lerobot_meta.h"
#include "ingest/parquet/parquet_file.h"
#include "tests/ingest/parquet_writer.h"

namespace wm::ingest::testing {
namespace fs = std::filesystem;
using namespace wm::parquet;
using namespace wm::parquet::testing;

namespace {

// One column of a file being written: its schema and, per row group, its rows.
struct OutColumn {
  LeafSpec leaf;
  std::vector<Column> groups;
};

std::string PlainValues(const Column& c) {
  switch (c.type) {
    case PhysicalType::kInt64:
      return PlainInt64(c.values.ints);
    case PhysicalType::kFloat:
      return PlainFloat({c.values.reals.begin(), c.values.reals.end()});
    case PhysicalType::kDouble:
      return PlainDouble(c.values.reals);
    case PhysicalType::kByteArray: {
      std::string out;
      for (const auto& s : c.values.strings) out += LengthBytes(s.size()) + s;
      return out;
    }
    default:
      throw Error("fixture writer: unsupported type of column " + c.path);
  }
}

// One uncompressed PLAIN data page v1 holding a whole column chunk. Lists have fixed-size rows
// here, so repetition levels are 0, 1, 1, ... per row and every definition level is the maximum.
ChunkSpec PlainChunk(const Column& c, bool list) {
  std::string payload;
  const int64_t n = static_cast<int64_t>(c.values.size());
  if (list) {
    std::vector<uint32_t> rep;
    for (int64_t r = 0; r < c.rows(); ++r) {
      for (int64_t i = 0; i < c.RowSize(r); ++i) rep.push_back(i == 0 ? 0 : 1);
    }
    payload = WithLength(BitPackedRun(rep, 1)) + WithLength(RleRun(3, n, 2));
  }
  payload += PlainValues(c);
  const PageSpec spec{.num_values = static_cast<int32_t>(n),
                      .raw_size = static_cast<int32_t>(payload.size())};
  return {Page(spec, payload), n};
}

void WriteParquet(const fs::path& path, const std::vector<OutColumn>& columns) {
  std::vector<LeafSpec> leaves;
  for (const auto& c : columns) leaves.push_back(c.leaf);
  std::vector<std::pair<int64_t, std::vector<ChunkSpec>>> groups(columns.front().groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    groups[g].first = columns.front().groups[g].rows();
    for (const auto& c : columns) {
      groups[g].second.push_back(PlainChunk(c.groups[g], c.leaf.path.size() > 1));
    }
  }
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << ParquetFileBytes(leaves, groups);
}

// A one-row-group column of int64 / double / string values.
OutColumn Scalars(const std::string& name, PhysicalType type, Values values) {
  Column c;
  c.path = name;
  c.type = type;
  c.values = std::move(values);
  for (size_t i = 0; i < c.values.size(); ++i) c.row_starts.push_back(static_cast<int64_t>(i + 1));
  return {ScalarLeaf(name, type, Repetition::kRequired), {c}};
}

// data/chunk-000/file-NNN.parquet: every column of the v2.1 files, one row group per episode.
void WriteDataFile(const LeRobotMeta& v21, const std::vector<int64_t>& episodes,
                   const fs::path& path) {
  std::vector<OutColumn> columns;
  for (int64_t episode : episodes) {
    const ParquetFile in((fs::path(v21.root) / v21.DataPath(v21.Episode(episode))).string());
    if (columns.empty()) {
      for (const auto& leaf : in.leaves()) {
        columns.push_back({leaf.max_repetition > 0
                               ? ListLeaf(leaf.field, leaf.type)
                               : ScalarLeaf(leaf.field, leaf.type, Repetition::kRequired),
                           {}});
      }
    }
    for (size_t i = 0; i < columns.size(); ++i) {
      columns[i].groups.push_back(in.Read(in.leaves()[i].path));
    }
  }
  WriteParquet(path, columns);
}

std::string FilePath(int64_t n, const std::string& ext) {
  char name[32];
  std::snprintf(name, sizeof(name), "file-%03lld.%s", static_cast<long long>(n), ext.c_str());
  return std::string("chunk-000/") + name;
}

// Which file of `files` holds `episode`.
int64_t FileOf(const std::vector<std::vector<int64_t>>& files, int64_t episode) {
  for (size_t f = 0; f < files.size(); ++f) {
    for (int64_t e : files[f]) {
      if (e == episode) return static_cast<int64_t>(f);
    }
  }
  throw Error("fixture: episode " + std::to_string(episode) + " is in no file");
}

}  // namespace

std::vector<std::pair<double, double>> ConcatenateVideos(const std::vector<std::string>& inputs,
                                                         const std::string& output) {
  av_log_set_level(AV_LOG_ERROR);
  AVFormatContext* out = nullptr;
  Check(avformat_alloc_output_context2(&out, nullptr, "mp4", output.c_str()) >= 0, "cannot create",
        {.file = output});
  AVStream* out_stream = nullptr;
  std::vector<std::pair<double, double>> spans;
  int64_t offset = 0;  // in the output stream's time base
  for (const std::string& path : inputs) {
    AVFormatContext* in = nullptr;
    Check(avformat_open_input(&in, path.c_str(), nullptr, nullptr) >= 0 &&
              avformat_find_stream_info(in, nullptr) >= 0,
          "cannot open", {.file = path});
    const int s = av_find_best_stream(in, AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
    Check(s >= 0, "no video stream", {.file = path});
    const AVStream* in_stream = in->streams[s];
    if (!out_stream) {
      out_stream = avformat_new_stream(out, nullptr);
      avcodec_parameters_copy(out_stream->codecpar, in_stream->codecpar);
      out_stream->codecpar->codec_tag = 0;
      out_stream->time_base = in_stream->time_base;
      Check(avio_open(&out->pb, output.c_str(), AVIO_FLAG_WRITE) >= 0 &&
                avformat_write_header(out, nullptr) >= 0,
            "cannot start writing", {.file = output});
    }
    const AVRational tb = out_stream->time_base;  // the muxer may have chosen its own
    int64_t end = offset;
    AVPacket* packet = av_packet_alloc();
    while (av_read_frame(in, packet) >= 0) {
      if (packet->stream_index == s) {
        av_packet_rescale_ts(packet, in_stream->time_base, tb);
        packet->pts += offset;
        packet->dts += offset;
        packet->stream_index = 0;
        end = std::max(end, packet->pts + packet->duration);
        Check(av_interleaved_write_frame(out, packet) >= 0, "cannot write a packet",
              {.file = output});
      }
      av_packet_unref(packet);
    }
    av_packet_free(&packet);
    avformat_close_input(&in);
    spans.push_back({offset * av_q2d(tb), end * av_q2d(tb)});
    offset = end;
  }
  av_write_trailer(out);
  avio_closep(&out->pb);
  avformat_free_context(out);
  return spans;
}

void WriteV30Fixture(const std::string& v21_root, const std::string& out_dir,
                     const V30FixtureOptions& o) {
  const LeRobotMeta v21 = ReadLeRobotMeta(v21_root);
  const fs::path root(out_dir);
  fs::remove_all(root);
  fs::create_directories(root / "meta");
  for (size_t f = 0; f < o.data_files.size(); ++f) {
    WriteDataFile(v21, o.data_files[f],
                  root / "data" / FilePath(static_cast<int64_t>(f), "parquet"));
  }
  // Episodes in meta/ order, with their global row range: the v2.1 rows' own `index` (the
  // sample lacks episodes, so episode 1 starts at 479).
  std::vector<int64_t> order;
  for (const auto& files : o.data_files) order.insert(order.end(), files.begin(), files.end());
  Values index, length, data_file, rows_from, rows_to;
  for (int64_t e : order) {
    const int64_t n = v21.Episode(e).length;
    const ParquetFile rows((fs::path(v21_root) / v21.DataPath(v21.Episode(e))).string());
    const int64_t row = rows.Read("index").values.ints.at(0);
    const int64_t file =
        e == o.misplaced_episode ? (FileOf(o.data_files, e) + 1) % 2 : FileOf(o.data_files, e);
    index.ints.push_back(e), length.ints.push_back(n), data_file.ints.push_back(file);
    rows_from.ints.push_back(row), rows_to.ints.push_back(row + n);
  }
  std::vector<OutColumn> columns = {Scalars("episode_index", PhysicalType::kInt64, index),
                                    Scalars("length", PhysicalType::kInt64, length),
                                    Scalars("data/chunk_index", PhysicalType::kInt64,
                                            {.ints = std::vector<int64_t>(order.size())}),
                                    Scalars("data/file_index", PhysicalType::kInt64, data_file),
                                    Scalars("dataset_from_index", PhysicalType::kInt64, rows_from),
                                    Scalars("dataset_to_index", PhysicalType::kInt64, rows_to)};
  for (const std::string& key : v21.video_keys) {
    std::map<int64_t, std::pair<double, double>> span;
    for (size_t f = 0; f < o.video_files.size(); ++f) {
      std::vector<std::string> inputs;
      for (int64_t e : o.video_files[f]) {
        inputs.push_back((fs::path(v21_root) / v21.VideoPath(v21.Episode(e), key)).string());
      }
      const fs::path out = root / "videos" / key / FilePath(static_cast<int64_t>(f), "mp4");
      fs::create_directories(out.parent_path());
      const auto spans = ConcatenateVideos(inputs, out.string());
      for (size_t i = 0; i < spans.size(); ++i) span[o.video_files[f][i]] = spans[i];
    }
    span[order.back()].second += o.extra_to_timestamp_s;
    Values file, from, to;
    for (int64_t e : order) {
      file.ints.push_back(FileOf(o.video_files, e));
      from.reals.push_back(span.at(e).first), to.reals.push_back(span.at(e).second);
    }
    const std::string prefix = "videos/" + key + "/";
    columns.push_back(Scalars(prefix + "chunk_index", PhysicalType::kInt64,
                              {.ints = std::vector<int64_t>(order.size())}));
    columns.push_back(Scalars(prefix + "file_index", PhysicalType::kInt64, file));
    columns.push_back(Scalars(prefix + "from_timestamp", PhysicalType::kDouble, from));
    columns.push_back(Scalars(prefix + "to_timestamp", PhysicalType::kDouble, to));
  }
  WriteParquet(root / "meta/episodes" / FilePath(0, "parquet"), columns);
  // tasks.parquet as pandas writes a DataFrame indexed by the task text (unnamed index).
  Values task_index, task_text;
  for (const auto& [i, text] : v21.tasks)
    task_index.ints.push_back(i), task_text.strings.push_back(text);
  WriteParquet(root / "meta/tasks.parquet",
               {Scalars("task_index", PhysicalType::kInt64, task_index),
                Scalars("__index_level_0__", PhysicalType::kByteArray, task_text)});
  std::ifstream in(fs::path(v21_root) / "meta/info.json");
  nlohmann::ordered_json info = nlohmann::ordered_json::parse(in);
  info["codebase_version"] = "v3.0";
  info["data_path"] = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
  info["video_path"] = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4";
  info["total_episodes"] = order.size();
  info.erase("total_chunks");
  info.erase("total_videos");
  std::ofstream(root / "meta/info.json") << info.dump(4);
}

}  // namespace wm::ingest::testing
