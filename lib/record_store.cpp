// SPDX-License-Identifier: MIT
// The two-slot record store (include/imucal/store/record_store.hpp).
#include "imucal/store/record_store.hpp"

#include <cstring>

#include "little_endian.hpp"

namespace imucal {
namespace {

using detail::load_u16;
using detail::load_u32;
using detail::store_u32;

constexpr std::uint16_t kCommitTag = 0xC35Au;

// a was written after b (sequence numbers wrap: serial-number arithmetic).
bool later(std::uint32_t a, std::uint32_t b) { return static_cast<std::int32_t>(a - b) > 0; }

std::uint32_t round_up(std::uint32_t n, std::uint32_t unit) {
  return (n + unit - 1) / unit * unit;  // n and unit are small (checked geometry)
}

// The seal: the commit's own CRC and its complement (erased flash, 0xFF, is no seal).
void stage_seal(std::uint8_t* seal, std::uint32_t commit_crc) {
  store_u32(seal, commit_crc);
  store_u32(seal + 4, ~commit_crc);
}
bool seal_matches(const std::uint8_t* seal, std::uint32_t commit_crc) {
  return load_u32(seal) == commit_crc && load_u32(seal + 4) == ~commit_crc;
}

// Releases the store's busy flag when a call returns.
class Guard {
 public:
  explicit Guard(std::atomic_flag& f)
      : flag_(f), owned_(!f.test_and_set(std::memory_order_acquire)) {}
  ~Guard() {
    if (owned_) flag_.clear(std::memory_order_release);
  }
  Guard(const Guard&) = delete;
  Guard& operator=(const Guard&) = delete;
  bool owned() const { return owned_; }

 private:
  std::atomic_flag& flag_;
  bool owned_;
};

}  // namespace

Status RecordStore::check_geometry(const FlashGeometry& g) const {
  if (!flash_geometry_nests(g)) return Status::kInvalidArgument;
  if ((g.size / g.erase_size) % 2 != 0) return Status::kInvalidArgument;  // two slots of units
  const std::uint32_t need = round_up(kCommitBytes, g.program_unit) +
                             round_up(static_cast<std::uint32_t>(kRecordMaxBytes), g.program_unit) +
                             round_up(kSealBytes, g.program_unit);
  if (g.size / 2 < need) return Status::kInvalidArgument;
  return Status::kOk;
}

Status RecordStore::check_geometry() const { return check_geometry(flash_.geometry()); }

void RecordStore::note_sequence(const Read& r) {
  if (!r.sequence_known) return;
  if (!sequence_seen_ || later(r.sequence, max_sequence_)) max_sequence_ = r.sequence;
  sequence_seen_ = true;
}

// One read of a slot: the commit, the record it names (decoded into `record` if valid; unchanged
// otherwise), then the seal after it.
RecordStore::Read RecordStore::read_once(int slot, CalibrationRecord& record) {
  const FlashGeometry g = flash_.geometry();
  const std::uint32_t base = slot_offset(slot);
  Read r;
  std::uint8_t commit[kCommitBytes];
  if (flash_.read(base, commit, kCommitBytes) != Status::kOk) {
    r.kind = Kind::kUnreadable;
    r.status = Status::kStorageError;
    return r;
  }
  const std::uint32_t seq = load_u32(commit), check = load_u32(commit + 4);
  const std::uint32_t length = load_u16(commit + 8);
  bool erased = true;
  for (std::uint8_t b : commit) erased = erased && b == 0xFF;
  if (erased) return r;  // kInvalid, kNoRecord
  if (seq != ~check || load_u16(commit + 10) != kCommitTag ||
      crc32(commit, 16) != load_u32(commit + 16) || length > kRecordMaxBytes) {
    r.status = Status::kRecordBadChecksum;  // a torn or corrupt commit
    return r;
  }
  r.sequence_known = true;
  r.sequence = seq;
  r.record_crc = load_u32(commit + 12);
  const std::uint32_t at = base + round_up(kCommitBytes, g.program_unit);
  if (flash_.read(at, buf_, length) != Status::kOk) {
    r.kind = Kind::kUnreadable;
    r.status = Status::kStorageError;
    return r;
  }
  if (crc32(buf_, length) != r.record_crc) {
    r.status = Status::kRecordBadChecksum;
    return r;
  }
  r.status = decode_record(buf_, length, record);
  if (r.status != Status::kOk) return r;
  r.kind = Kind::kValid;
  std::uint8_t seal[kSealBytes];
  if (flash_.read(at + round_up(length, g.program_unit), seal, kSealBytes) == Status::kOk &&
      seal_matches(seal, load_u32(commit + 16)))
    r.kind = Kind::kSealed;
  return r;
}

// Reads a slot until a read finds it sealed, at most kReadAttempts times: a burst of up to
// kReadAttempts - 1 misreads of the slot leaves one read right, and no misread makes a read
// valid (it cannot match both CRC-32s), so the best read is the truth.
RecordStore::View RecordStore::scan(int slot, CalibrationRecord* out) {
  View v;
  CalibrationRecord record;
  bool readable = false;
  Status last = Status::kStorageError;  // what the last read that read anything found
  for (int k = 0; k < kReadAttempts && v.rank != Rank::kSealed; ++k) {
    const Read r = read_once(slot, record);
    note_sequence(r);
    if (r.kind == Kind::kUnreadable) continue;
    readable = true;
    if (r.kind == Kind::kInvalid) {
      last = r.status;
      continue;
    }
    const Rank rank = r.kind == Kind::kSealed ? Rank::kSealed : Rank::kValid;
    if (rank <= v.rank) continue;
    v.rank = rank;
    v.sequence = r.sequence;
    if (out != nullptr) *out = record;
  }
  const bool valid = v.rank >= Rank::kValid;
  if (!valid) v.rank = readable ? Rank::kNothing : Rank::kUnreadable;
  Slot& s = slots_[slot];
  s.status = valid ? Status::kOk : last;
  s.sequence = valid ? v.sequence : 0;
  s.sealed = v.rank == Rank::kSealed;
  return v;
}

Status RecordStore::load(CalibrationRecord& out) {
  const Guard guard(busy_);
  if (!guard.owned()) return Status::kStorageBusy;
  return load_locked(out);
}

Status RecordStore::load_locked(CalibrationRecord& out) {
  if (check_geometry() != Status::kOk) return Status::kInvalidArgument;
  // Slot 1's record goes straight to `out`: only a valid one is written there, and with one the
  // load succeeds (with it, or with slot 0's if that is newer).
  CalibrationRecord record0;
  View v[2];
  v[0] = scan(0, &record0);
  v[1] = scan(1, &out);
  // The newest sealed record; failing that, the newest whose save did not finish.
  int newest = -1;
  for (const Rank want : {Rank::kSealed, Rank::kValid}) {
    for (int k = 0; k < 2; ++k)
      if (v[k].rank == want && (newest < 0 || later(v[k].sequence, v[newest].sequence))) newest = k;
    if (newest >= 0) break;
  }
  if (newest < 0)
    return v[0].rank == Rank::kUnreadable || v[1].rank == Rank::kUnreadable ? Status::kStorageError
                                                                            : Status::kNoRecord;
  if (newest == 0) out = record0;
  return Status::kOk;
}

Status RecordStore::program_range(std::uint32_t offset, const std::uint8_t* data,
                                  std::uint32_t size) {
  const std::uint32_t page = flash_.geometry().page_size;
  while (size > 0) {
    const std::uint32_t room = page - offset % page;
    const std::uint32_t n = size < room ? size : room;
    const Status s = flash_.program(offset, data, n);
    if (s != Status::kOk) return s;
    offset += n;
    data += n;
    size -= n;
  }
  return Status::kOk;
}

// The slot to write: the one worth less (sealed > valid > unreadable > nothing), of two sealed
// or two valid ones the older; never one of two unreadable slots (either may hold the record).
int RecordStore::choose_target(const View v[2]) {
  if (v[0].rank != v[1].rank) return v[0].rank < v[1].rank ? 0 : 1;
  switch (v[0].rank) {
    case Rank::kSealed:
    case Rank::kValid:
      return later(v[0].sequence, v[1].sequence) ? 1 : 0;
    case Rank::kUnreadable:
      return -1;
    case Rank::kNothing:
      break;
  }
  return 0;
}

Status RecordStore::save(const CalibrationRecord& record) {
  const Guard guard(busy_);
  if (!guard.owned()) return Status::kStorageBusy;
  return save_locked(record);
}

Status RecordStore::save_locked(const CalibrationRecord& record) {
  const FlashGeometry g = flash_.geometry();
  if (check_geometry(g) != Status::kOk) return Status::kInvalidArgument;
  {  // Refuse a record the encoder refuses before touching the flash.
    const Status enc = encode_record(record, buf_, kRecordMaxBytes, nullptr);
    if (enc != Status::kOk) return enc;
  }
  View v[2];
  for (int k = 0; k < 2; ++k) v[k] = scan(k, nullptr);
  const int target = choose_target(v);
  if (target < 0) return Status::kStorageError;  // both unreadable: erase neither
  const std::uint32_t seq = sequence_seen_ ? max_sequence_ + 1u : 1u;

  std::size_t size = 0;
  const Status enc = encode_record(record, buf_, kRecordMaxBytes, &size);
  if (enc != Status::kOk) return enc;
  const std::uint32_t n = static_cast<std::uint32_t>(size);
  const std::uint32_t padded = round_up(n, g.program_unit);
  std::memset(buf_ + n, 0xFF, padded - n);
  const std::uint32_t record_crc = crc32(buf_, n);

  const std::uint32_t base = slot_offset(target);
  const std::uint32_t commit_area = round_up(kCommitBytes, g.program_unit);
  const std::uint32_t seal_at = base + commit_area + padded;
  const std::uint32_t seal_area = round_up(kSealBytes, g.program_unit);
  slots_[target] = Slot{};
  // Erase from the slot's start: the commit's unit goes first, so the slot stops counting before
  // any of its record changes.
  for (std::uint32_t at = 0; at < slot_size(); at += g.erase_size) {
    const Status s = flash_.erase(base + at);
    if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;
  }
  // The record first, then the commit, then the seal, each program unit once.
  Status s = program_range(base + commit_area, buf_, padded);
  std::uint32_t commit_crc = 0;
  if (s == Status::kOk) {
    std::uint8_t* c = buf_;  // the record is no longer needed in RAM: stage the commit
    std::memset(c, 0xFF, commit_area);
    store_u32(c, seq);
    store_u32(c + 4, ~seq);
    c[8] = static_cast<std::uint8_t>(n & 0xFFu);
    c[9] = static_cast<std::uint8_t>(n >> 8);
    c[10] = static_cast<std::uint8_t>(kCommitTag & 0xFFu);
    c[11] = static_cast<std::uint8_t>(kCommitTag >> 8);
    store_u32(c + 12, record_crc);
    commit_crc = crc32(c, 16);
    store_u32(c + 16, commit_crc);
    s = program_range(base, c, commit_area);
  }
  if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;

  // The seal last: the commit and the record were programmed completely.
  std::memset(buf_, 0xFF, seal_area);
  stage_seal(buf_, commit_crc);
  s = program_range(seal_at, buf_, seal_area);
  if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;

  // Read back until one read finds the commit, the record it names and the seal (a burst of
  // misreads passes).
  bool readable = false, sealed = false;
  CalibrationRecord back_record;
  for (int k = 0; k < kReadAttempts && !sealed; ++k) {
    const Read back = read_once(target, back_record);
    note_sequence(back);
    readable = readable || back.kind != Kind::kUnreadable;
    sealed = back.kind == Kind::kSealed && back.sequence == seq && back.record_crc == record_crc;
  }
  if (!sealed) return readable ? Status::kStorageVerifyFailed : Status::kStorageError;
  slots_[target] = Slot{Status::kOk, seq, true};
  return Status::kOk;
}

Status RecordStore::erase_all() {
  const Guard guard(busy_);
  if (!guard.owned()) return Status::kStorageBusy;
  const FlashGeometry g = flash_.geometry();
  if (check_geometry(g) != Status::kOk) return Status::kInvalidArgument;
  for (std::uint32_t at = 0; at < g.size; at += g.erase_size) {
    const Status s = flash_.erase(at);
    if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;
  }
  slots_[0] = slots_[1] = Slot{};
  return Status::kOk;
}

}  // namespace imucal
