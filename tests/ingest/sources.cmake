# Tests of the HDF5 and folder readers; their fixtures are written by the tests themselves
# (HDF5 C API, cv::imwrite), so they link HDF5 / OpenCV directly.
wm_add_test(hdf5_source_test SOURCES hdf5_source_test.cc
  LIBS wm_ingest wm_test_util wm_hdf5 opencv_core opencv_imgproc opencv_imgcodecs)
wm_add_test(folder_source_test SOURCES folder_source_test.cc
  LIBS wm_ingest wm_test_util opencv_core opencv_imgcodecs)
# The Parquet reader on files written by a small test writer (also used for the fuzz seeds).
add_library(wm_parquet_test_writer STATIC parquet_writer.cc)
target_link_libraries(wm_parquet_test_writer PUBLIC wm_parquet PRIVATE Snappy::snappy wm_warnings)
target_include_directories(wm_parquet_test_writer PUBLIC ${PROJECT_SOURCE_DIR})
wm_add_test(parquet_test SOURCES parquet_test.cc LIBS wm_parquet wm_parquet_test_writer)
# The LeRobot reader on the real v2.1 sample in ../shared (skipped where it is absent).
wm_add_test(lerobot_test SOURCES lerobot_test.cc LIBS wm_ingest wm_parquet wm_test_util)
# The v3.0 LeRobot reader on fixtures built from the v2.1 sample at test time (test Parquet
# writer + MP4 remuxing with libavformat; docs/lerobot-mapping.md, "v3.0 test fixtures").
add_library(wm_lerobot_v30_fixture STATIC lerobot_v30_fixture.cc)
target_link_libraries(wm_lerobot_v30_fixture PUBLIC wm_ingest wm_parquet_test_writer
  PRIVATE PkgConfig::LIBAV nlohmann_json::nlohmann_json wm_warnings)
target_include_directories(wm_lerobot_v30_fixture PUBLIC ${PROJECT_SOURCE_DIR})
wm_add_test(lerobot_v30_test SOURCES lerobot_v30_test.cc LIBS wm_lerobot_v30_fixture wm_ingest wm_parquet wm_test_util)
# wm-ingest --suggest-mapping on the samples in ../shared (skipped where absent).
wm_add_test(suggest_mapping_test SOURCES suggest_mapping_test.cc
  LIBS wm_lerobot_v30_fixture wm_ingest wm_rlds wm_test_util)
