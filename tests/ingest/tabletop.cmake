wm_add_test(tabletop_test SOURCES tabletop_test.cc LIBS wm_tabletop wm_rlds opencv_imgcodecs)
wm_add_test(sim_policy_test SOURCES sim_policy_test.cc LIBS wm_sim_policy wm_tabletop wm_test_util)
