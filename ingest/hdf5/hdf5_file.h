#pragma once
// Thin RAII layer over the HDF5 C API for hdf5_source.cc: one process-wide lock, owned hid_t
// handles, and the few queries the robomimic/LIBERO reader needs. Internal to wm_ingest.
#include <hdf5.h>

#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace wm::ingest::h5 {

// Debian builds libhdf5 without --enable-threadsafe, so every HDF5 call, handle closes included,
// happens while a Lock is alive. Declare handles after the lock so they close before it unlocks.
class Lock {
 public:
  Lock();

 private:
  std::lock_guard<std::mutex> lock_;
};

// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  Handle(Handle&& other) noexcept;
  Handle& operator=(Handle&& other) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle();
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// Whether `path` ("a/b/c", relative to `loc`) exists.
bool Exists(hid_t loc, const std::string& path);
// Names of a group's members, sorted. Throws wm::Error (no context) when one is unreadable.
std::vector<std::string> ChildNames(hid_t group);
// Read-only; throws wm::Error naming `path` when it is not a readable HDF5 file.
Handle OpenFile(const std::string& path);
// Invalid (!ok()) when `name` is not a group.
Handle OpenGroup(hid_t loc, const std::string& name);
// A scalar string attribute, variable or fixed length (as h5py writes str or numpy bytes);
// nullopt when absent. Throws wm::Error (no context) when it is not one string.
std::optional<std::string> ReadStringAttr(hid_t obj, const char* name);

struct Dataset {
  Handle id, type;  // id invalid when the path is not a dataset
  H5T_class_t cls = H5T_NO_CLASS;
  size_t bytes = 0;  // per element
  bool is_signed = false;
  std::vector<hsize_t> dims;
  hsize_t stored_bytes = 0;  // raw data bytes the file holds for it (compressed, if filtered),
                             // at most the file's size

  bool IsUnsignedInt(size_t width) const;
  size_t NumElements() const;  // SIZE_MAX when the product of dims overflows
  // Whether the dims could describe the stored data: at most what deflate (robomimic's and
  // LIBERO's gzip filter, at most 1032:1) expands stored_bytes to. A damaged dataspace can
  // declare any size, and ReadAll's buffer must not be sized blindly from it.
  bool DimsFitStoredData() const;
  // e.g. "float64 [50, 6]", for error messages.
  std::string Describe() const;
  // Every element, converted by HDF5 from the file type to `mem_type`; false on failure.
  bool ReadAll(hid_t mem_type, void* out) const;
};

Dataset OpenDataset(hid_t loc, const std::string& path);

}  // namespace wm::ingest::h5
