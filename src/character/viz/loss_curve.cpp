#include "gatcore/character/viz/loss_curve.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "gatcore/character/viz/plot.hpp"
#include "gatcore/atomic_file.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::string format_history(const std::vector<LossRecord>& h) {
  std::string s;
  char b[160];
  for (const LossRecord& r : h) {
    std::snprintf(b, sizeof b, "%s%d:%.9g:%.9g:%.6g:%.4g", s.empty() ? "" : ";", r.epoch, r.train, r.val, r.lr,
                  r.seconds);
    s += b;
    if (r.val_l1 >= 0) {
      std::snprintf(b, sizeof b, ":%.9g", r.val_l1);
      s += b;
      if (r.val_dominant >= 0) {
        std::snprintf(b, sizeof b, ":%.9g", r.val_dominant);
        s += b;
      }
    }
  }
  return s;
}

std::vector<LossRecord> parse_history(const std::string& s, const std::string& what) {
  std::vector<LossRecord> h;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ';');) {
    LossRecord r;
    // Five fields, six with the validation L1, seven with the dominant-bone
    // accuracy, and nothing after them.
    int end5 = -1, end6 = -1, end7 = -1;
    const int got = std::sscanf(item.c_str(), "%d:%lf:%lf:%lf:%lf%n:%lf%n:%lf%n", &r.epoch, &r.train, &r.val, &r.lr,
                                &r.seconds, &end5, &r.val_l1, &end6, &r.val_dominant, &end7);
    const int len = static_cast<int>(item.size());
    if (!(got == 5 && end5 == len) && !(got == 6 && end6 == len) &&
        !(got == 7 && end7 == len && r.val_dominant >= 0 && r.val_dominant <= 1))
      throw InvalidArgument(what + ": malformed loss history entry '" + item + "'");
    h.push_back(r);
  }
  return h;
}

std::string default_curve_path(const std::string& checkpoint) {
  const auto slash = checkpoint.find_last_of('/');
  const auto dot = checkpoint.find_last_of('.');
  const bool ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  return (ext ? checkpoint.substr(0, dot) : checkpoint) + ".loss.png";
}

std::string history_csv_path(const std::string& png) {
  if (png.size() > 4 && png.compare(png.size() - 4, 4, ".png") == 0) return png.substr(0, png.size() - 4) + ".csv";
  return png + ".csv";
}

void write_loss_outputs(const std::vector<LossRecord>& h, const std::string& png) {
  const std::string csv = history_csv_path(png);
  {
    std::string f = "epoch,train_loss,val_loss,lr,seconds,val_l1,val_dominant\n";
    char b[240], v[40] = "", l1[40] = "", dom[40] = "";
    for (const LossRecord& r : h) {
      if (r.val >= 0) std::snprintf(v, sizeof v, "%.9g", r.val);
      else v[0] = 0;  // no validation set: an empty field
      if (r.val_l1 >= 0) std::snprintf(l1, sizeof l1, "%.9g", r.val_l1);
      else l1[0] = 0;  // not a skin-weight model, or not validated this epoch
      if (r.val_dominant >= 0) std::snprintf(dom, sizeof dom, "%.9g", r.val_dominant);
      else dom[0] = 0;
      std::snprintf(b, sizeof b, "%d,%.9g,%s,%.6g,%.4g,%s,%s\n", r.epoch, r.train, v, r.lr, r.seconds, l1, dom);
      f += b;
    }
    write_file_atomic(csv, f);
  }
  PlotSeries train{"train", {}, {}}, val{"validation", {}, {}}, l1{"validation L1", {}, {}};
  for (const LossRecord& r : h) {
    train.x.push_back(float(r.epoch));
    train.y.push_back(float(r.train));
    if (r.val >= 0) {
      val.x.push_back(float(r.epoch));
      val.y.push_back(float(r.val));
    }
    if (r.val_l1 >= 0) {
      l1.x.push_back(float(r.epoch));
      l1.y.push_back(float(r.val_l1));
    }
  }
  std::vector<PlotSeries> series{train};
  if (!val.x.empty()) series.push_back(val);
  if (!l1.x.empty()) series.push_back(l1);
  write_png(png, plot_series(series));
}

}  // namespace gatcore::character
