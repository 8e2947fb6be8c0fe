// imucal/store/record_store.hpp: keeps the calibration record in a small flash region so that a
// power cut at ANY moment, or any single fault of the flash (a torn unit, an ECC error, a weak bit,
// a misread, a failure reported for a write that completed), leaves the old record or the new one
// readable, never neither. Never allocates or throws; blocks only inside the flash port's calls.
//
// The region (a FlashRegion, ports/include/imucal/store/flash_region.hpp) is split into two slots
// of whole erase units. A slot holds, from its start:
//   the commit, padded to whole program units:
//     sequence number (u32, little-endian), its complement (u32), record length (u16),
//     0xC35A (u16), CRC-32 of the record's bytes (u32), CRC-32 of these 16 bytes (u32)
//   the record (record.hpp), padded with 0xFF to whole program units
// Every program unit is programmed at most once per erase (flash with ECC forbids more), so the
// store works on flash that programs in units of 1 to 256 bytes.
//
// save() chooses the slot that does NOT hold the newest valid record, reads the slot it keeps
// once more, erases the other (the commit's unit first), programs the record, then the commit
// last. Until the commit is complete and matches the record the slot does not count. Then it
// reads the slot back. Each slot is read until two reads agree (at most four; unreadable only if
// the last two of four fail): a slot that reads differently each time is torn; one that cannot
// be read may still hold a good record, so
// save() never erases it while the other slot is not known good (it returns kStorageError and
// changes nothing). The new sequence number follows the largest one ever read from a commit, so
// it never restarts while a record exists. load() returns the valid record with the later
// sequence number (serial-number arithmetic: wraps).
//
// Threads and interrupts: one RecordStore per region, and no other writer of that region. Its
// calls block for flash erases: call them from a task, never from an interrupt. A call made
// while another is running on the same object (another task) returns kStorageBusy at once and
// touches nothing; the store holds no lock.
#pragma once

#include <atomic>
#include <cstdint>

#include "imucal/status.hpp"
#include "imucal/store/flash_region.hpp"
#include "imucal/store/record.hpp"

namespace imucal {

class RecordStore {
 public:
  static constexpr std::uint32_t kCommitBytes = 20;
  static constexpr std::uint32_t kMaxProgramUnit = 256;

  explicit RecordStore(FlashRegion& flash) : flash_(flash) {}
  RecordStore(const RecordStore&) = delete;
  RecordStore& operator=(const RecordStore&) = delete;

  // kOk if the geometry nests (flash_geometry_nests()), the region splits into two slots of
  // whole erase units, and each slot holds the commit and the largest record, each padded to
  // whole program units; kInvalidArgument otherwise. load() and save() check it too.
  Status check_geometry() const;

  // The newest valid record. kNoRecord if neither slot holds one (erased, torn or corrupt: see
  // slot_status()); kStorageError if no slot holds a valid record and one could not be read.
  // `out` is unchanged unless kOk.
  Status load(CalibrationRecord& out);

  // Writes the record with the next sequence number into the other slot. kOk only after it was
  // read back intact; on any failure the previously newest record is still the one load()
  // returns (or the new one, if the failure came after it was complete). A record
  // encode_record() refuses gets its status (kInvalidArgument, kImplausible).
  Status save(const CalibrationRecord& record);

  // Erases both slots: the only way out when neither slot can be read (save() refuses then).
  Status erase_all();

  // After load() or save(): what each slot held at the last scan (kOk: a valid record; else
  // kNoRecord, a record status, or kStorageError: unreadable or reading differently each time)
  // and its sequence number (0 unless kOk).
  Status slot_status(int slot) const { return slots_[slot & 1].status; }
  std::uint32_t slot_sequence(int slot) const { return slots_[slot & 1].sequence; }

 private:
  enum class Kind : std::uint8_t { kValid, kInvalid, kUnreadable };
  struct Read {  // one read of a slot
    Kind kind = Kind::kInvalid;
    Status status = Status::kNoRecord;
    bool sequence_known = false;  // the commit was intact (the record may not be)
    std::uint32_t sequence = 0;
    std::uint32_t record_crc = 0;
  };
  struct View {  // a slot after reading it until two reads agree
    Read read;
    bool settled = false;     // two consecutive reads agreed
    bool ever_valid = false;  // some read found a valid record
    bool ever_unreadable = false;
  };
  struct Slot {
    Status status = Status::kNoRecord;
    std::uint32_t sequence = 0;
  };

  Status check_geometry(const FlashGeometry& g) const;
  Read read_once(int slot, CalibrationRecord* out);
  View read_settled(int slot, CalibrationRecord* out);
  static bool good(const View& v);
  static int choose_target(const View v[2]);
  void note_sequence(const Read& r);
  Status program_range(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size);
  Status load_locked(CalibrationRecord& out);
  Status save_locked(const CalibrationRecord& record);
  std::uint32_t slot_offset(int slot) const { return slot == 0 ? 0 : slot_size(); }
  std::uint32_t slot_size() const { return flash_.geometry().size / 2; }

  FlashRegion& flash_;
  Slot slots_[2];
  bool sequence_seen_ = false;
  std::uint32_t max_sequence_ = 0;  // the largest sequence read from any commit
  std::atomic_flag busy_ = ATOMIC_FLAG_INIT;
  // The record padded to whole program units (the commit is staged here too, after it).
  std::uint8_t buf_[kRecordMaxBytes + kMaxProgramUnit] = {};
};

}  // namespace imucal
