// SPDX-License-Identifier: MIT
// imucal/solve/move_store.hpp: the moves between poses as gyro segments (math.md section 4),
// in a store of fixed capacity. The move in progress grows segment by segment, each merged with
// the previous one while the merged one stays a small, nearly single-axis rotation (the path
// angle and |alpha||beta| bounds); a pose ends it and it is recorded from its pose to the new
// one. When the store is full, the adjacent segments of the same move whose merge costs least
// are merged (exact algebra) until an eighth of it is free, and the bounds double: accuracy
// degrades gracefully instead of data being lost. Only when every move is one segment is the
// move in progress dropped. Header-only, no allocation.
#pragma once

#include <cmath>
#include <cstddef>

#include "imucal/models/accel_model.hpp"
#include "imucal/solve/gyro_calibration.hpp"
#include "imucal/stream/gyro_segment.hpp"

namespace imucal {

// A rest's rotation split at its time centroid (first order: the rotation within a rest is a
// fraction of a degree). With gamma = sum_{k<l} dt_k dt_l (u_k - u_l) = sum u_k dt_k (T - 2 m_k)
// (m_k the middle of interval k), the centroid's attitude is reached after alpha/2 + gamma/2T
// and the rest of alpha follows; each half holds T/2 of the bias (alpha_b = alpha + T/2 b).
// False (nothing written) for a rest without duration.
template <typename Scalar>
bool split_rest_rotation(const GyroSegment<Scalar>& r, GyroSegment<Scalar>& head,
                         GyroSegment<Scalar>& tail) {
  if (!(r.duration > Scalar(0))) return false;
  const Vector3<Scalar> half = Scalar(0.5) * r.alpha, skew = r.gamma / (Scalar(2) * r.duration);
  head = GyroSegment<Scalar>{};
  tail = GyroSegment<Scalar>{};
  head.alpha = half + skew;
  tail.alpha = half - skew;
  head.duration = tail.duration = Scalar(0.5) * r.duration;
  return true;
}

template <typename Scalar, int MaxMoves, int MaxSegments>
class MoveStore {
 public:
  static_assert(MaxMoves > 0 && MaxSegments > 0, "empty store");

  // Empty, with the bounds of a new segment: path angle and |alpha||beta| (raw units).
  void reset(Scalar max_angle, Scalar max_error) {
    seg_count_ = move_count_ = 0;
    chain_from_ = -1;
    move_first_ = 0;
    moves_dropped_ = coarsenings_ = 0;
    last_mergeable_ = tail_only_ = false;
    rotation_.setZero();
    bounds_.set(max_angle, max_error);
  }

  // A rotation of `path` (its path angle) appended to the move in progress; nothing without one
  // (no pose to start from yet, or the move was dropped).
  void add(const GyroSegment<Scalar>& seg, Scalar path) {
    if (chain_from_ < 0) return;
    tail_only_ = false;
    if (last_mergeable_ && seg_count_ > move_first_ && last_path_ + path <= bounds_.max_angle) {
      GyroSegment<Scalar> merged = segments_[seg_count_ - 1];
      merged.append(seg);
      if (merged.alpha.squaredNorm() * merged.beta.squaredNorm() <= bounds_.max_error2) {
        segments_[seg_count_ - 1] = merged;
        last_path_ += path;
        return;
      }
    }
    const bool first = seg_count_ == move_first_;
    if (!store(seg)) {
      if (first) ++moves_dropped_;  // drop() counts a move only once it holds segments
      return;
    }
    last_path_ = path;
    last_mergeable_ = true;
  }

  // A pose (index `pose`) is reached: the move in progress, if it has segments, is recorded as
  // ending there, and the next one starts from it. A rest that turned (held in the hand) gives
  // its halves: head ends the move into it, tail starts the move out of it (both or neither).
  void arrive(int pose, const GyroSegment<Scalar>* head, const GyroSegment<Scalar>* tail) {
    if (head != nullptr && in_move()) store(*head);
    if (in_move()) {
      GyroMove& m = moves_[move_count_++];
      m.first_segment = move_first_;
      m.segments = seg_count_ - move_first_;
      m.from_pose = chain_from_;
      m.to_pose = pose;
      for (int k = m.first_segment; k < seg_count_; ++k) rotation_ += segments_[k].alpha.cwiseAbs();
    }
    chain_from_ = pose;
    move_first_ = seg_count_;
    last_mergeable_ = false;
    if (tail != nullptr) {
      store(*tail);
      tail_only_ = true;
    }
  }

  // The move in progress cannot be used (a gap, a frozen or saturated sensor, no pose to end
  // at): its segments are freed, the chain starts again at the next pose.
  void drop() {
    if (in_move() && !tail_only_) ++moves_dropped_;
    tail_only_ = false;
    seg_count_ = move_first_;
    chain_from_ = -1;
    last_mergeable_ = false;
  }

  // A move in progress that holds segments.
  bool in_move() const { return chain_from_ >= 0 && seg_count_ > move_first_; }
  // A move is in progress (a pose to start from, not dropped since), with segments or not.
  bool chained() const { return chain_from_ >= 0; }

  // For a store that hands its move on as it grows (the rest monitor) rather than recording it:
  // the oldest segment of the move in progress, removed. Only once a later segment follows it
  // (the newest may still grow), or with newest_too once nothing more is added. False when none
  // is ready, or once moves were recorded (arrive() ended one).
  bool pop_oldest(GyroSegment<Scalar>& out, bool newest_too) {
    if (move_count_ != 0 || seg_count_ - move_first_ < (newest_too ? 1 : 2)) return false;
    out = segments_[move_first_];
    for (int k = move_first_ + 1; k < seg_count_; ++k) segments_[k - 1] = segments_[k];
    --seg_count_;
    return true;
  }
  // Segments ready for pop_oldest(): all but the newest, or all with newest_too.
  int ready(bool newest_too) const {
    const int n = move_count_ != 0 ? 0 : seg_count_ - move_first_;
    return newest_too ? n : (n > 1 ? n - 1 : 0);
  }

  int move_count() const { return move_count_; }
  const GyroMove& move(int i) const { return moves_[i]; }
  const GyroMove* moves() const { return moves_; }
  int segment_count() const { return seg_count_; }
  const GyroSegment<Scalar>& segment(int i) const { return segments_[i]; }
  const GyroSegment<Scalar>* segments() const { return segments_; }
  int moves_dropped() const { return moves_dropped_; }
  int coarsenings() const { return coarsenings_; }
  // |alpha| per body axis, summed over the recorded moves (which axes were turned about).
  const Vector3<Scalar>& rotation() const { return rotation_; }

  // The bounds a new segment is held to (they double with every coarsening).
  const SegmentBounds<Scalar>& bounds() const { return bounds_; }

 private:
  // A new segment at the end of the store, coarsening it when full; false (the move dropped)
  // when nothing is left to merge (one segment per move everywhere).
  bool store(const GyroSegment<Scalar>& seg) {
    if (seg_count_ == MaxSegments) coarsen();
    if (seg_count_ == MaxSegments) {
      drop();
      return false;
    }
    segments_[seg_count_++] = seg;
    last_mergeable_ = false;
    return true;
  }

  // Frees at least an eighth of the store by merging adjacent segments of the same move (exact
  // algebra), those whose merged error bound is smallest first: the bound tau starts at the
  // current one and doubles until enough merges qualify. The new-segment bounds double too, so
  // that a long protocol (or an unknown gyro scale) settles at a coarser resolution instead of
  // coarsening often.
  void coarsen() {
    const int wanted = MaxSegments / 8 > 0 ? MaxSegments / 8 : 1;
    Scalar tau = bounds_.max_error;
    for (int attempt = 0; attempt < 40 && merge_pass(tau, false) < wanted; ++attempt)
      tau *= Scalar(2);
    merge_pass(tau, true);
    bounds_.max_angle *= Scalar(2);
    bounds_.set_error(Scalar(2) * bounds_.max_error);
    last_mergeable_ = false;
    ++coarsenings_;
  }

  // Greedy left-to-right merging within each move (the recorded ones and the open one) while
  // |alpha||beta| of the merged segment stays within tau. Returns the number of merges; with
  // apply, also performs them and compacts the store.
  int merge_pass(Scalar tau, bool apply) {
    int merges = 0, write = 0;
    auto range = [&](int first, int count) {
      const int new_first = write;
      if (count == 0) return new_first;
      GyroSegment<Scalar> cur = segments_[first];
      for (int k = 1; k < count; ++k) {
        GyroSegment<Scalar> trial = cur;
        trial.append(segments_[first + k]);
        if (trial.alpha.squaredNorm() * trial.beta.squaredNorm() <= tau * tau) {
          cur = trial;
          ++merges;
          continue;
        }
        if (apply) segments_[write] = cur;
        ++write;
        cur = segments_[first + k];
      }
      if (apply) segments_[write] = cur;
      ++write;
      return new_first;
    };
    for (int m = 0; m < move_count_; ++m) {
      const int first = range(moves_[m].first_segment, moves_[m].segments);
      if (apply) {
        moves_[m].first_segment = first;
        moves_[m].segments = write - first;
      }
    }
    const int open_first = range(move_first_, seg_count_ - move_first_);
    if (apply) {
      move_first_ = open_first;
      seg_count_ = write;
    }
    return merges;
  }

  GyroSegment<Scalar> segments_[static_cast<std::size_t>(MaxSegments)] = {};
  GyroMove moves_[static_cast<std::size_t>(MaxMoves)] = {};
  int seg_count_ = 0, move_count_ = 0;
  int chain_from_ = -1;  // the pose the move in progress starts from (-1: none)
  int move_first_ = 0;   // its first segment
  int moves_dropped_ = 0, coarsenings_ = 0;
  Scalar last_path_ = Scalar(0);  // the path angle of the newest segment
  SegmentBounds<Scalar> bounds_{};
  Vector3<Scalar> rotation_ = Vector3<Scalar>::Zero();
  bool last_mergeable_ = false;  // the newest segment may grow
  bool tail_only_ = false;       // the move in progress holds only its pose's rest half so far
};

}  // namespace imucal
