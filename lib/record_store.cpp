// The two-slot record store (include/imucal/record_store.hpp).
#include "imucal/record_store.hpp"

#include <cstring>

#include "little_endian.hpp"

namespace imucal {
namespace {

using detail::load_u32;
using detail::store_u32;

// a was written after b (sequence numbers wrap: serial-number arithmetic).
bool later(std::uint32_t a, std::uint32_t b) { return static_cast<std::int32_t>(a - b) > 0; }

}  // namespace

Status RecordStore::check_geometry() const {
  const FlashGeometry g = flash_.geometry();
  if (g.erase_size == 0 || g.page_size == 0 || g.erase_size % g.page_size != 0 ||
      g.size % (2 * g.erase_size) != 0)
    return Status::kInvalidArgument;
  if (g.size / 2 < kSlotHeaderBytes + kRecordMaxBytes) return Status::kInvalidArgument;
  return Status::kOk;
}

Status RecordStore::read_slot(int slot, CalibrationRecord& out) {
  const std::uint32_t base = slot_offset(slot);
  Slot& s = slots_[slot];
  s = Slot{};
  const Status r = flash_.read(base, buf_, sizeof buf_);
  if (r != Status::kOk) return s.status = Status::kStorageError;
  const std::uint32_t seq = load_u32(buf_), check = load_u32(buf_ + 4);
  if (seq != ~check) return s.status = Status::kNoRecord;  // erased, or the commit was cut
  s.status = decode_record(buf_ + kSlotHeaderBytes, kRecordMaxBytes, out);  // out kept on failure
  if (s.status == Status::kOk) s.sequence = seq;
  return s.status;
}

int RecordStore::scan(CalibrationRecord* newest_record) {
  int newest = -1;
  CalibrationRecord record;
  for (int k = 0; k < 2; ++k) {
    const Status s = read_slot(k, record);
    if (s == Status::kStorageError) return -2;
    if (s != Status::kOk) continue;
    if (newest < 0 || later(slots_[k].sequence, slots_[newest].sequence)) {
      newest = k;
      if (newest_record != nullptr) *newest_record = record;
    }
  }
  return newest;
}

Status RecordStore::load(CalibrationRecord& out) {
  if (check_geometry() != Status::kOk) return Status::kInvalidArgument;
  CalibrationRecord newest_record;
  const int newest = scan(&newest_record);
  if (newest == -2) return Status::kStorageError;
  if (newest < 0) return Status::kNoRecord;
  out = newest_record;
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

Status RecordStore::save(const CalibrationRecord& record) {
  if (check_geometry() != Status::kOk) return Status::kInvalidArgument;
  const int newest = scan(nullptr);
  if (newest == -2) return Status::kStorageError;
  const int target = newest < 0 ? 0 : 1 - newest;
  const std::uint32_t seq = newest < 0 ? 1u : slots_[newest].sequence + 1u;

  std::size_t size = 0;
  const Status enc = encode_record(record, buf_ + kSlotHeaderBytes, kRecordMaxBytes, &size);
  if (enc != Status::kOk) return enc;
  store_u32(buf_, seq);
  store_u32(buf_ + 4, ~seq);

  const FlashGeometry g = flash_.geometry();
  const std::uint32_t base = slot_offset(target);
  for (std::uint32_t at = 0; at < slot_size(); at += g.erase_size) {
    const Status s = flash_.erase(base + at);
    if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;
  }
  // The record first, the sequence header last: the slot counts only once both are complete.
  const std::uint32_t n = static_cast<std::uint32_t>(size);
  Status s = program_range(base + kSlotHeaderBytes, buf_ + kSlotHeaderBytes, n);
  if (s == Status::kOk) s = program_range(base, buf_, kSlotHeaderBytes);
  if (s != Status::kOk) return s == Status::kInvalidArgument ? s : Status::kStorageError;

  // Read back what was meant to be there (the buffer is reused: keep a CRC of it).
  const std::uint32_t expected = crc32(buf_, kSlotHeaderBytes + n);
  if (flash_.read(base, buf_, kSlotHeaderBytes + n) != Status::kOk) return Status::kStorageError;
  if (crc32(buf_, kSlotHeaderBytes + n) != expected) return Status::kStorageVerifyFailed;
  slots_[target].status = Status::kOk;
  slots_[target].sequence = seq;
  return Status::kOk;
}

}  // namespace imucal
