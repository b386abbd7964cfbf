wm_add_test(tabletop_test SOURCES tabletop_test.cc LIBS wm_tabletop wm_rlds opencv_imgcodecs)
