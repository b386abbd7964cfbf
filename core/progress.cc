#include "core/progress.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "core/log.h"

namespace wm {

Progress::Progress(std::string label, uint64_t total, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), total_(total), tty_(::isatty(2) == 1) {
  start_ = last_render_ = std::chrono::steady_clock::now();
}

Progress::~Progress() { Finish(); }

void Progress::Add(uint64_t n) {
  if (n == 0) return;
  std::lock_guard<std::mutex> lock(mu_);
  done_ += n;
  auto now = std::chrono::steady_clock::now();
  double since = std::chrono::duration<double>(now - last_render_).count();
  if (tty_ ? since > 0.1 : true) Render(false);
}

void Progress::Finish() {
  std::lock_guard<std::mutex> lock(mu_);
  if (finished_) return;
  finished_ = true;
  Render(true);
}

std::string Progress::FormatDuration(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--";
  long total = std::lround(s);
  char buf[32];
  if (total >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%02ld:%02ld", total / 60, total % 60);
  }
  return buf;
}

std::string Progress::FormatLine(const std::string& label, uint64_t done, uint64_t total,
                                 const std::string& unit, double elapsed_s, int bar_width) {
  double rate = elapsed_s > 0 ? static_cast<double>(done) / elapsed_s : 0.0;
  char buf[256];
  if (total == 0) {
    std::snprintf(buf, sizeof buf, "%s %llu %s %.1f %s/s %s", label.c_str(),
                  static_cast<unsigned long long>(done), unit.c_str(), rate, unit.c_str(),
                  FormatDuration(elapsed_s).c_str());
    return buf;
  }
  double frac = std::min(1.0, static_cast<double>(done) / static_cast<double>(total));
  std::string bar;
  if (bar_width > 0) {
    int filled = static_cast<int>(frac * bar_width);
    bar = "|" + std::string(filled, '#') + std::string(bar_width - filled, ' ') + "| ";
  }
  double eta = rate > 0 ? static_cast<double>(total - std::min(done, total)) / rate : NAN;
  std::snprintf(buf, sizeof buf, "%s %3.0f%% %s%llu/%llu %s  %.1f %s/s  ETA %s", label.c_str(),
                100.0 * frac, bar.c_str(), static_cast<unsigned long long>(done),
                static_cast<unsigned long long>(total), unit.c_str(), rate, unit.c_str(),
                FormatDuration(eta).c_str());
  return buf;
}

void Progress::Render(bool final) {
  auto now = std::chrono::steady_clock::now();
  double elapsed = std::chrono::duration<double>(now - start_).count();
  if (tty_) {
    last_render_ = now;
    std::fprintf(stderr, "\r%s\033[K%s",
                 FormatLine(label_, done_, total_, unit_, elapsed, 30).c_str(), final ? "\n" : "");
    std::fflush(stderr);
    return;
  }
  int decile = total_ > 0 ? static_cast<int>(10 * done_ / total_) : -1;
  double since = std::chrono::duration<double>(now - last_render_).count();
  bool news = done_ != last_logged_done_;
  if (news && (final || decile > last_logged_decile_ || since >= 10.0)) {
    last_logged_decile_ = decile;
    last_logged_done_ = done_;
    last_render_ = now;
    spdlog::info("{}", FormatLine(label_, done_, total_, unit_, elapsed, 0));
  }
}

}  // namespace wm
