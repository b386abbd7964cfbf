#include "ingest/hdf5/hdf5_file.h"

#include <algorithm>
#include <cstring>
#include <utility>

#include "core/error.h"

namespace wm::ingest::h5 {
namespace {

std::mutex& Mutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

Lock::Lock() : lock_(Mutex()) {
  // Failures become wm::Error; HDF5's own error-stack dump on stderr would only add noise.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

Handle::Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, -1)), close_(other.close_) {}

Handle& Handle::operator=(Handle&& other) noexcept {
  std::swap(id_, other.id_);
  std::swap(close_, other.close_);
  return *this;
}

Handle::~Handle() {
  if (id_ >= 0) close_(id_);
}

// H5Lexists fails on "a/b" when "a" is missing, so each path component is checked in turn.
bool Exists(hid_t loc, const std::string& path) {
  for (size_t end = path.find('/');; end = path.find('/', end + 1)) {
    if (H5Lexists(loc, path.substr(0, end).c_str(), H5P_DEFAULT) <= 0) return false;
    if (end == std::string::npos) return true;
  }
}

std::vector<std::string> ChildNames(hid_t group) {
  H5G_info_t info;
  if (H5Gget_info(group, &info) < 0) return {};
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    ssize_t n =
        H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    std::string name(static_cast<size_t>(std::max<ssize_t>(n, 0)), '\0');
    // A member whose name cannot be read is damage, not a member to leave out silently.
    Check(n >= 0 && H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(),
                                       n + 1, H5P_DEFAULT) == n,
          "cannot read the name of member " + std::to_string(i) + " of a group (damaged file?)");
    names.push_back(std::move(name));
  }
  std::sort(names.begin(), names.end());
  return names;
}

Handle OpenFile(const std::string& path) {
  Check(H5Fis_hdf5(path.c_str()) > 0, "not an HDF5 file, or unreadable", {path});
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  Check(file.ok(), "cannot open HDF5 file (damaged?)", {path});
  return file;
}

Handle OpenGroup(hid_t loc, const std::string& name) {
  return {H5Gopen2(loc, name.c_str(), H5P_DEFAULT), H5Gclose};
}

std::optional<std::string> ReadStringAttr(hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) return std::nullopt;
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  Check(H5Tget_class(type.get()) == H5T_STRING && H5Sget_simple_extent_npoints(space.get()) == 1,
        std::string("attribute '") + name + "' is not a single string");
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  // Matching the file's character set avoids HDF5 refusing an ASCII <-> UTF-8 conversion.
  H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
  const std::string cannot_read = std::string("cannot read attribute '") + name + "'";
  if (H5Tis_variable_str(type.get()) > 0) {
    H5Tset_size(mem.get(), H5T_VARIABLE);
    char* text = nullptr;
    Check(H5Aread(attr.get(), mem.get(), &text) >= 0 && text != nullptr, cannot_read);
    std::string out(text);
    H5free_memory(text);
    return out;
  }
  size_t size = H5Tget_size(type.get());
  // The type's size is read from the file; the attribute must actually store that many bytes.
  Check(size <= H5Aget_storage_size(attr.get()), cannot_read + ": larger than its stored data");
  H5Tset_size(mem.get(), size);
  H5Tset_strpad(mem.get(), H5T_STR_NULLPAD);  // NULLTERM would drop the last of `size` chars
  std::string out(size, '\0');
  Check(H5Aread(attr.get(), mem.get(), out.data()) >= 0, cannot_read);
  out.resize(strnlen(out.data(), size));
  return out;
}

bool Dataset::IsUnsignedInt(size_t width) const {
  return cls == H5T_INTEGER && bytes == width && !is_signed;
}

size_t Dataset::NumElements() const {
  size_t n = 1;
  for (hsize_t d : dims) {
    if (__builtin_mul_overflow(n, d, &n)) return SIZE_MAX;
  }
  return n;
}

bool Dataset::DimsFitStoredData() const {
  constexpr uint64_t kMaxDeflateExpansion = 1032;
  const uint64_t element_bytes = std::max<uint64_t>(bytes, 1);  // 0 when the type is unreadable
  uint64_t logical = 0;
  return NumElements() != SIZE_MAX &&
         !__builtin_mul_overflow(NumElements(), element_bytes, &logical) &&
         logical / kMaxDeflateExpansion <= stored_bytes;
}

std::string Dataset::Describe() const {
  std::string bits = std::to_string(bytes * 8);
  std::string out = cls == H5T_FLOAT     ? "float" + bits
                    : cls == H5T_INTEGER ? (is_signed ? "int" : "uint") + bits
                    : cls == H5T_ENUM    ? "enum" + bits
                    : cls == H5T_STRING  ? "string"
                                         : "non-numeric";
  out += " [";
  for (size_t i = 0; i < dims.size(); ++i) out += (i ? ", " : "") + std::to_string(dims[i]);
  return out + "]";
}

bool Dataset::ReadAll(hid_t mem_type, void* out) const {
  return H5Dread(id.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) >= 0;
}

Dataset OpenDataset(hid_t loc, const std::string& path) {
  Dataset d;
  d.id = Handle(H5Dopen2(loc, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.id.ok()) return d;
  d.type = Handle(H5Dget_type(d.id.get()), H5Tclose);
  Handle space(H5Dget_space(d.id.get()), H5Sclose);
  d.cls = H5Tget_class(d.type.get());
  d.bytes = H5Tget_size(d.type.get());
  d.is_signed = d.cls == H5T_INTEGER && H5Tget_sign(d.type.get()) == H5T_SGN_2;
  // The storage size is layout metadata, which damage can set to anything: cap it at the file's.
  Handle file(H5Iget_file_id(d.id.get()), H5Fclose);
  hsize_t file_bytes = 0;
  if (!file.ok() || H5Fget_filesize(file.get(), &file_bytes) < 0) file_bytes = 0;
  d.stored_bytes = std::min(H5Dget_storage_size(d.id.get()), file_bytes);
  int rank = H5Sget_simple_extent_ndims(space.get());
  d.dims.resize(static_cast<size_t>(std::max(rank, 0)));
  H5Sget_simple_extent_dims(space.get(), d.dims.data(), nullptr);
  return d;
}

}  // namespace wm::ingest::h5
