// SPDX-License-Identifier: MIT
// imucal/store/record_store.hpp: keeps the calibration record in a small flash region. Never
// allocates or throws; blocks only inside the flash port's calls.
//
// The promise: after save() returned kOk, load() returns that record or a newer one, whatever
// single fault follows; and two faults never lose both records (load() still returns the last
// record saved with kOk, or a newer one). A fault is a power cut at any moment (the unit being
// programmed or erased left torn: an ECC error, arbitrary bits, or a weak bit that reads
// differently from one read to the next), a failure reported for a step that completed, or a
// burst of up to kMaxMisreads misreads of one area (reads that fail, or return flipped bits).
// test_record_store checks it for every step of a save on ECC flash of 1 to 256 byte units.
//
// The region (a FlashRegion, ports/include/imucal/store/flash_region.hpp) is split into two slots
// of whole erase units. A slot holds, from its start, each part padded to whole program units:
//   the commit: sequence number (u32, little-endian), its complement (u32), record length (u16),
//     0xC35A (u16), CRC-32 of the record's bytes (u32), CRC-32 of these 16 bytes (u32);
//   the record (record.hpp);
//   the seal: the commit's CRC-32 (u32) and its complement (u32).
// Every program unit is programmed at most once per erase (flash with ECC forbids more), so the
// store works on flash that programs in units of 1 to 256 bytes.
//
// A slot is valid if a read of it finds the commit and the record it names with both CRC-32s
// right, and sealed if that read also finds the seal. A misread cannot make a read valid: the
// CRC-32s detect every error of up to 3 bits in the record and of up to 5 in the commit, every
// burst of up to 32 bits, and miss any other with a chance of about 2^-32. So a slot is read until
// a read finds it sealed, at most kReadAttempts times (kMaxMisreads + 1): a burst of misreads
// leaves one read right, and the best read is the truth.
//
// save() writes one slot: erase (the commit's unit first), program the record, then the commit,
// then the seal, then read the slot back; kOk only once a read finds it sealed. The seal says
// that the commit and the record were programmed completely: a commit torn by a cut in its last
// unit may read right sometimes, but it is never sealed. So save() writes the slot worth less
// (sealed > valid > unreadable > nothing; of two sealed or two valid slots the older) and keeps the
// other: it never erases the only sealed copy, and a record saved with kOk is sealed. Of two
// unreadable slots it erases neither (either may hold a good record): it returns kStorageError and
// changes nothing, and erase_all() is the way out. The new sequence number follows the largest
// ever read from a commit, so it never restarts while a record exists. load() returns the newest
// sealed record, failing that the newest valid one (serial-number arithmetic: wraps).
//
// Cost per call, at most: load() 2 x kReadAttempts x 3 flash reads (24: commit, record, seal;
// a slot's reads stop at the first sealed read); save() those 24, the slot's erase units, its
// program units (commit, record, seal), then kReadAttempts x 3 reads back (12): 36 reads. Without
// a fault: a sealed slot is read once (3 reads), an empty one kReadAttempts times (its commit
// only), the new slot once.
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
  static constexpr std::uint32_t kSealBytes = 8;
  static constexpr std::uint32_t kMaxProgramUnit = 256;
  static constexpr int kMaxMisreads = 3;                  // reads of one slot in a burst, at most
  static constexpr int kReadAttempts = kMaxMisreads + 1;  // reads of a slot per scan, at most

  explicit RecordStore(FlashRegion& flash) : flash_(flash) {}
  RecordStore(const RecordStore&) = delete;
  RecordStore& operator=(const RecordStore&) = delete;

  // kOk if the geometry nests (flash_geometry_nests()), the region splits into two slots of
  // whole erase units, and each slot holds the commit, the largest record and the seal, each
  // padded to whole program units; kInvalidArgument otherwise. load() and save() check it too.
  Status check_geometry() const;

  // The newest sealed record, failing that the newest valid one. kNoRecord if neither slot
  // holds one (erased, torn or corrupt: see slot_status()); kStorageError if no slot holds a
  // valid record and one could not be read. `out` is unchanged unless kOk.
  Status load(CalibrationRecord& out);

  // Writes the record with the next sequence number into the slot worth less (see above). kOk
  // only after it was read back intact and sealed; on any failure the record load() returned
  // before is still the one it returns, or the new one (kStorageError: the flash failed or
  // neither slot could be read; kStorageVerifyFailed: read back wrong). A record
  // encode_record() refuses gets its status (kInvalidArgument, kImplausible).
  Status save(const CalibrationRecord& record);

  // Erases both slots: the only way out when neither slot can be read (save() refuses then).
  Status erase_all();

  // After load() or save(): what each slot held at the last scan (kOk: a valid record; else
  // kNoRecord, a record status, or kStorageError: no read of it succeeded), its sequence number
  // (0 unless kOk) and whether it is sealed (its save completed).
  Status slot_status(int slot) const { return slots_[slot & 1].status; }
  std::uint32_t slot_sequence(int slot) const { return slots_[slot & 1].sequence; }
  bool slot_sealed(int slot) const { return slots_[slot & 1].sealed; }

 private:
  enum class Kind : std::uint8_t { kInvalid, kUnreadable, kValid, kSealed };
  struct Read {  // one read of a slot
    Kind kind = Kind::kInvalid;
    Status status = Status::kNoRecord;
    bool sequence_known = false;  // the commit was intact (the record may not be)
    std::uint32_t sequence = 0;
    std::uint32_t record_crc = 0;
  };
  // What a slot is worth keeping, least first: nothing valid in any read that succeeded; no
  // read succeeded; a valid record in some read; sealed in some read.
  enum class Rank : std::uint8_t { kNothing, kUnreadable, kValid, kSealed };
  struct View {  // a slot after scan()
    Rank rank = Rank::kNothing;
    std::uint32_t sequence = 0;  // of the best read (kValid, kSealed)
  };
  struct Slot {
    Status status = Status::kNoRecord;
    std::uint32_t sequence = 0;
    bool sealed = false;
  };

  Status check_geometry(const FlashGeometry& g) const;
  Read read_once(int slot, CalibrationRecord& record);
  View scan(int slot, CalibrationRecord* out);
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
  // The record padded to whole program units (the commit and the seal are staged here too).
  std::uint8_t buf_[kRecordMaxBytes + kMaxProgramUnit] = {};
};

}  // namespace imucal
