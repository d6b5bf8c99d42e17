// The SfM front end's own part of the front-end summary: its JSON both ways (sfm_summary.hpp).
#include "smseg/sfm/sfm_summary.hpp"

#include "smseg/frontend/tracks_io.hpp"

namespace smseg::sfm {

Json SfmSummary::to_json() const {
  return {{"tracker", tracker},
          {"focal_px", focal},
          {"focal_source", focal_source},
          {"focal_pairs", focal_pairs},
          {"init_pair", {init_frame_a, init_frame_b}},
          {"keyframes", keyframes},
          {"posed_frames", posed_frames},
          {"still_frames", still_frames},
          {"bridged_frames", bridged_frames},
          {"points_3d", points_3d},
          {"map_joins", map_joins},
          {"observations", observations},
          {"reprojection_rms_px", reprojection_rms_px},
          {"scale_m_per_unit", scale},
          {"ground_inliers", ground_inliers},
          {"ground_candidates", ground_candidates},
          {"seconds_per_frame", {{"sfm", seconds_sfm}, {"bundle_adjustment", seconds_ba}}}};
}

std::shared_ptr<const frontend::SummaryPart> sfm_summary_part(const JsonView& m) {
  auto f = std::make_shared<SfmSummary>();
  f->tracker = m.str("tracker");
  f->focal = m.num("focal_px");
  f->focal_source = m.str("focal_source");
  f->focal_pairs = static_cast<int>(m.integer("focal_pairs"));
  const auto init = frontend::integers(m.at("init_pair"), 2);
  f->init_frame_a = static_cast<int>(init[0]);
  f->init_frame_b = static_cast<int>(init[1]);
  f->keyframes = static_cast<int>(m.integer("keyframes"));
  f->posed_frames = static_cast<int>(m.integer("posed_frames"));
  f->still_frames = static_cast<int>(m.integer("still_frames"));
  f->bridged_frames = static_cast<int>(m.integer("bridged_frames"));
  f->points_3d = m.integer("points_3d");
  f->map_joins = m.has("map_joins") ? m.integer("map_joins") : 0;  // files before local-map matching
  f->observations = m.integer("observations");
  f->reprojection_rms_px = m.num("reprojection_rms_px");
  f->scale = m.num("scale_m_per_unit");
  f->ground_inliers = static_cast<int>(m.integer("ground_inliers"));
  f->ground_candidates = static_cast<int>(m.integer("ground_candidates"));
  f->seconds_sfm = m.at("seconds_per_frame").num("sfm");
  f->seconds_ba = m.at("seconds_per_frame").num("bundle_adjustment");
  return f;
}

const SfmSummary* sfm_summary_of(const frontend::FrontEndSummary& summary) {
  return dynamic_cast<const SfmSummary*>(summary.own.get());
}

}  // namespace smseg::sfm
