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
constexpr int kMaxReads = 4;  // reads of a slot until two agree (unreadable: all of them)

// a was written after b (sequence numbers wrap: serial-number arithmetic).
bool later(std::uint32_t a, std::uint32_t b) { return static_cast<std::int32_t>(a - b) > 0; }

std::uint32_t round_up(std::uint32_t n, std::uint32_t unit) {
  return (n + unit - 1) / unit * unit;  // n and unit are small (checked geometry)
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
                             round_up(static_cast<std::uint32_t>(kRecordMaxBytes), g.program_unit);
  if (g.size / 2 < need) return Status::kInvalidArgument;
  return Status::kOk;
}

Status RecordStore::check_geometry() const { return check_geometry(flash_.geometry()); }

void RecordStore::note_sequence(const Read& r) {
  if (!r.sequence_known) return;
  if (!sequence_seen_ || later(r.sequence, max_sequence_)) max_sequence_ = r.sequence;
  sequence_seen_ = true;
}

// One read of a slot: the commit, then the record it names.
RecordStore::Read RecordStore::read_once(int slot, CalibrationRecord* out) {
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
  CalibrationRecord decoded;
  r.status = decode_record(buf_, length, decoded);
  if (r.status != Status::kOk) return r;
  r.kind = Kind::kValid;
  if (out != nullptr) *out = decoded;
  return r;
}

RecordStore::View RecordStore::read_settled(int slot, CalibrationRecord* out) {
  View v;
  CalibrationRecord record;
  Read previous;
  for (int k = 0; k < kMaxReads; ++k) {
    const Read r = read_once(slot, &record);
    note_sequence(r);
    v.ever_valid = v.ever_valid || r.kind == Kind::kValid;
    v.ever_unreadable = v.ever_unreadable || r.kind == Kind::kUnreadable;
    if (r.kind == Kind::kValid && out != nullptr) *out = record;  // the last valid read
    // Unreadable settles only on the last reads: a burst of read errors is not a torn slot.
    const bool may_settle = r.kind != Kind::kUnreadable || k == kMaxReads - 1;
    if (k > 0 && may_settle && r.kind == previous.kind && r.status == previous.status &&
        r.sequence_known == previous.sequence_known && r.sequence == previous.sequence &&
        r.record_crc == previous.record_crc) {
      v.read = r;
      v.settled = true;
      break;
    }
    previous = r;
    v.read = r;
  }
  Slot& s = slots_[slot];
  s.status = v.settled ? v.read.status : Status::kStorageError;
  s.sequence = v.settled && v.read.kind == Kind::kValid ? v.read.sequence : 0;
  return v;
}

Status RecordStore::load(CalibrationRecord& out) {
  const Guard guard(busy_);
  if (!guard.owned()) return Status::kStorageBusy;
  return load_locked(out);
}

Status RecordStore::load_locked(CalibrationRecord& out) {
  if (check_geometry() != Status::kOk) return Status::kInvalidArgument;
  CalibrationRecord records[2];
  View v[2];
  for (int k = 0; k < 2; ++k) v[k] = read_settled(k, &records[k]);
  // Records read valid on every read first; failing those, one that read valid at least once
  // (a slot that reads differently each time still holds the best record there is).
  int newest = -1;
  for (int pass = 0; pass < 2 && newest < 0; ++pass)
    for (int k = 0; k < 2; ++k) {
      const bool candidate =
          pass == 0 ? (v[k].settled && v[k].read.kind == Kind::kValid) : v[k].ever_valid;
      if (!candidate) continue;
      if (newest < 0 || later(v[k].read.sequence, v[newest].read.sequence)) newest = k;
    }
  if (newest < 0)
    return v[0].ever_unreadable || v[1].ever_unreadable ? Status::kStorageError : Status::kNoRecord;
  out = records[newest];
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

bool RecordStore::good(const View& v) { return v.settled && v.read.kind == Kind::kValid; }

// The slot to write: not the newest good one; never one that may hold the only good record.
int RecordStore::choose_target(const View v[2]) {
  const bool g0 = good(v[0]), g1 = good(v[1]);
  if (g0 && g1) return later(v[0].read.sequence, v[1].read.sequence) ? 1 : 0;
  if (g0 || g1) return g0 ? 1 : 0;
  // A slot that read valid once, or could not be read, may hold the only good record.
  const bool maybe0 = v[0].ever_valid || v[0].ever_unreadable;
  const bool maybe1 = v[1].ever_valid || v[1].ever_unreadable;
  if (!maybe0) return 0;
  if (!maybe1) return 1;
  return -1;
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
  for (int k = 0; k < 2; ++k) v[k] = read_settled(k, nullptr);
  // The slot kept must still read as it did right before the other one is erased. A kept slot
  // that reads otherwise is read again until two reads agree: a misread passes, a torn slot is
  // no longer taken for good and the choice is made again (at most once more).
  int target = -1;
  for (int attempt = 0; attempt < 2; ++attempt) {
    target = choose_target(v);
    if (target < 0) return Status::kStorageError;  // both uncertain: erase neither
    const int keep = 1 - target;
    if (!good(v[keep])) break;
    const Read again = read_once(keep, nullptr);
    if (again.kind == Kind::kValid && again.sequence == v[keep].read.sequence &&
        again.record_crc == v[keep].read.record_crc)
      break;
    const View before = v[keep];
    v[keep] = read_settled(keep, nullptr);
    v[keep].ever_valid = true;  // it did read valid: it may hold the only good record
    if (good(v[keep]) && v[keep].read.sequence == before.read.sequence &&
        v[keep].read.record_crc == before.read.record_crc)
      break;
    v[keep].settled = false;
    if (attempt == 1) return Status::kStorageError;
  }
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
  slots_[target] = Slot{};
  // Erase from the slot's start: the commit's unit goes first, so the slot stops counting before
  // any of its record changes.
  for (std::uint32_t at = 0; at < slot_size(); at += g.erase_size) {
    const Status s = flash_.erase(base + at);
    if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;
  }
  // The record first, the commit last, each program unit once.
  Status s = program_range(base + commit_area, buf_, padded);
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
    store_u32(c + 16, crc32(c, 16));
    s = program_range(base, c, commit_area);
  }
  if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;

  // Read back: the commit and the record it names.
  const Read back = read_once(target, nullptr);
  note_sequence(back);
  if (back.kind == Kind::kUnreadable) return Status::kStorageError;
  if (back.kind != Kind::kValid || back.sequence != seq || back.record_crc != record_crc)
    return Status::kStorageVerifyFailed;
  slots_[target].status = Status::kOk;
  slots_[target].sequence = seq;
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
