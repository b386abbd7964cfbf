# Tests of the HDF5 and folder readers; their fixtures are written by the tests themselves
# (HDF5 C API, cv::imwrite), so they link HDF5 / OpenCV directly.
wm_add_test(hdf5_source_test SOURCES hdf5_source_test.cc
  LIBS wm_ingest wm_test_util wm_hdf5 opencv_core opencv_imgproc opencv_imgcodecs)
wm_add_test(folder_source_test SOURCES folder_source_test.cc
  LIBS wm_ingest wm_test_util opencv_core opencv_imgcodecs)
