# Input readers of wm_ingest beyond RLDS: robomimic/LIBERO HDF5 and image folders. Included by
# ingest/CMakeLists.txt after wm_ingest is defined (OpenCV comes with wm_ingest's own links).
target_sources(wm_ingest PRIVATE hdf5/hdf5_file.cc hdf5/hdf5_source.cc hdf5/raw_demo.cc
  folder/folder_source.cc)
target_link_libraries(wm_ingest PRIVATE wm_hdf5)
