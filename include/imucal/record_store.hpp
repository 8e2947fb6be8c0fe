// imucal/record_store.hpp: keeps the calibration record in a small flash region so that a power
// cut at ANY moment leaves the old record or the new one readable, never neither. Never
// allocates or throws; blocks only inside the flash port's own calls.
//
// The region (a FlashRegion, ports/include/imucal/port/flash_region.hpp) is split into two slots
// of whole erase units. A slot holds, from its start:
//   sequence number (u32, little-endian), its complement (u32), the record (record.hpp)
// save() writes the slot that does NOT hold the newest valid record: erase, program the record,
// then program the 8-byte sequence header last (the commit). Until that header is complete the
// slot does not count (the sequence and its complement disagree, or the record's CRC fails), so
// the other slot's record stays the newest. Then it reads the slot back and compares. load()
// returns the valid record with the later sequence number (serial-number arithmetic: wraps).
#pragma once

#include <cstdint>

#include "imucal/port/flash_region.hpp"
#include "imucal/record.hpp"
#include "imucal/status.hpp"

namespace imucal {

class RecordStore {
 public:
  static constexpr std::uint32_t kSlotHeaderBytes = 8;

  explicit RecordStore(FlashRegion& flash) : flash_(flash) {}

  // kOk if the region splits into two slots of whole erase units, each large enough for the
  // largest record; kInvalidArgument otherwise. load() and save() check it too.
  Status check_geometry() const;

  // The newest valid record. kNoRecord if neither slot holds one (erased, torn or corrupt: see
  // slot_status()); kStorageError if the port failed. `out` is unchanged unless kOk.
  Status load(CalibrationRecord& out);

  // Writes the record with the next sequence number into the other slot. kOk only after it was
  // read back intact; on any failure the previously newest record is still the one load()
  // returns. kInvalidArgument for a record encode_record() refuses.
  Status save(const CalibrationRecord& record);

  // After load() or save(): what each slot held at the last scan (kOk: a valid record, else
  // why not) and its sequence number.
  Status slot_status(int slot) const { return slots_[slot & 1].status; }
  std::uint32_t slot_sequence(int slot) const { return slots_[slot & 1].sequence; }

 private:
  struct Slot {
    Status status = Status::kNoRecord;
    std::uint32_t sequence = 0;
  };

  // Reads both slots; returns the index of the newest valid one (its record into
  // *newest_record if given), or -1 (kStorageError: -2).
  int scan(CalibrationRecord* newest_record);
  Status read_slot(int slot, CalibrationRecord& out);  // out: the slot's record if kOk
  Status program_range(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size);
  std::uint32_t slot_offset(int slot) const { return slot == 0 ? 0 : slot_size(); }
  std::uint32_t slot_size() const { return flash_.geometry().size / 2; }

  FlashRegion& flash_;
  Slot slots_[2];
  std::uint8_t buf_[kSlotHeaderBytes + kRecordMaxBytes] = {};
};

}  // namespace imucal
