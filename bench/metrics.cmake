# metrics_bench: SSIM + PSNR throughput of wm_metrics; metrics_bench.py runs it beside
# scikit-image on the same pairs.
add_executable(metrics_bench metrics_bench.cc)
target_link_libraries(metrics_bench PRIVATE wm_metrics CLI11::CLI11 wm_warnings)
