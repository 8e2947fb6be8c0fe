// The two-slot record store on the simulated NOR flash: save and load, sequence numbers that
// wrap, a corrupt slot falling back to the other, and power cut at every byte operation of a
// save (erase and program): afterwards the old or the new record is read, never neither, and
// the next save succeeds.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>

#include "imucal/port/sim_nor_flash.hpp"
#include "imucal/record_store.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

// Two slots of one 1 KB erase unit each, 64-byte pages: every record crosses several pages.
using Flash = SimNorFlash<2048, 1024, 64>;

CalibrationRecord record(std::uint32_t id, bool with_gyro = true) {
  CalibrationRecord r;
  r.device_id = id;
  r.sensor_id = 0x6A68;
  r.parts = static_cast<std::uint16_t>(kRecordAccel | (with_gyro ? kRecordGyro : 0));
  Calibration<float>& c = r.calibration;
  c.accel.params << 0.002f, -0.001f, 0.0007f, 0.0024f, 0.0024f, 0.0024f, -32990.0f, -32770.5f,
      static_cast<float>(id);
  c.accel.sigma.setConstant(1e-5f);
  c.accel.poses = 30;
  c.accel.status = Status::kOk;
  if (with_gyro) {
    c.gyro.params << 0.003f, -0.002f, 0.001f, -0.004f, 0.0025f, -0.0015f, 2.1e-4f, 2.1e-4f, 2.1e-4f,
        -32750.0f, -32800.5f, static_cast<float>(id);
    c.gyro.sigma.setConstant(2e-5f);
    c.gyro.moves = 29;
    c.gyro.status = Status::kOk;
  }
  c.quality = Quality::kGood;
  c.sample_rate_hz = 100.0f;
  return r;
}

TEST(RecordStore, EmptyFlashHasNoRecord) {
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  EXPECT_EQ(store.check_geometry(), Status::kOk);
  CalibrationRecord out;
  EXPECT_EQ(store.load(out), Status::kNoRecord);
  EXPECT_EQ(store.slot_status(0), Status::kNoRecord);
  EXPECT_EQ(store.slot_status(1), Status::kNoRecord);
}

TEST(RecordStore, SavesAlternateSlotsAndLoadTheNewest) {
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  for (std::uint32_t id = 1; id <= 5; ++id) {
    ASSERT_EQ(store.save(record(id)), Status::kOk);
    CalibrationRecord out;
    ASSERT_EQ(store.load(out), Status::kOk);
    EXPECT_EQ(out.device_id, id);
    EXPECT_EQ(out.calibration.gyro.params(kGyroBiasZ), static_cast<float>(id));
    // The previous record stays in the other slot until the next save.
    if (id > 1) {
      EXPECT_EQ(store.slot_status(0), Status::kOk);
      EXPECT_EQ(store.slot_status(1), Status::kOk);
      EXPECT_EQ(store.slot_sequence(static_cast<int>(id - 1) & 1), id);
    }
  }
  // A fresh store (after a reboot) finds the same newest record.
  RecordStore again(flash);
  CalibrationRecord out;
  ASSERT_EQ(again.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 5u);
}

// Writes a slot header by hand (the first 8 bytes of a slot): sequence and complement.
void set_sequence(Flash& flash, int slot, std::uint32_t seq) {
  std::uint8_t* p = flash.raw() + slot * 1024;
  for (int i = 0; i < 4; ++i) {
    p[i] = static_cast<std::uint8_t>(seq >> (8 * i));
    p[4 + i] = static_cast<std::uint8_t>(~seq >> (8 * i));
  }
}

TEST(RecordStore, SequenceNumbersWrap) {
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  ASSERT_EQ(store.save(record(1)), Status::kOk);  // slot 0
  ASSERT_EQ(store.save(record(2)), Status::kOk);  // slot 1
  set_sequence(flash, 0, 0xFFFFFFFEu);
  set_sequence(flash, 1, 0xFFFFFFFFu);
  CalibrationRecord out;
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 2u);
  ASSERT_EQ(store.save(record(3)), Status::kOk);  // sequence 0 after 0xFFFFFFFF: newer
  EXPECT_EQ(store.slot_sequence(0), 0u);
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 3u);
}

TEST(RecordStore, ACorruptSlotFallsBackToTheOther) {
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  ASSERT_EQ(store.save(record(1)), Status::kOk);
  ASSERT_EQ(store.save(record(2)), Status::kOk);  // slot 1 is the newest
  flash.raw()[1024 + 8 + 50] ^= 0x10;             // one bit flips in its record
  CalibrationRecord out;
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 1u);
  EXPECT_EQ(store.slot_status(1), Status::kRecordBadChecksum);
  // The next save overwrites the corrupt slot, not the good one.
  ASSERT_EQ(store.save(record(3)), Status::kOk);
  EXPECT_EQ(store.slot_status(0), Status::kOk);
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 3u);
  // Both corrupt: no record, said so.
  flash.raw()[8 + 10] ^= 0x01;
  flash.raw()[1024 + 8 + 10] ^= 0x01;
  EXPECT_EQ(store.load(out), Status::kNoRecord);
  EXPECT_EQ(store.slot_status(0), Status::kRecordBadChecksum);
}

TEST(RecordStore, BadGeometryAndFailingFlashAreReported) {
  static SimNorFlash<1024, 512, 64> tiny;  // 512-byte slots: too small for the largest record
  RecordStore small(tiny);
  CalibrationRecord out;
  EXPECT_EQ(small.check_geometry(), Status::kInvalidArgument);
  EXPECT_EQ(small.load(out), Status::kInvalidArgument);
  EXPECT_EQ(small.save(record(1)), Status::kInvalidArgument);
  static Flash flash;
  flash = Flash();
  RecordStore store(flash);
  CalibrationRecord invalid = record(1);
  invalid.calibration.accel.params(kScaleX) = 0.0f;
  EXPECT_EQ(store.save(invalid), Status::kInvalidArgument);
  flash.cut_power_after(0);
  EXPECT_EQ(store.save(record(1)), Status::kStorageError);
  EXPECT_EQ(store.load(out), Status::kStorageError);  // no power, no read
}

TEST(SimNorFlash, BehavesAsNorFlash) {
  static SimNorFlash<1024, 256, 32> f;
  const std::uint8_t a[4] = {0xF0, 0x0F, 0x55, 0xFF};
  const std::uint8_t b[4] = {0x3C, 0xFF, 0xFF, 0x00};
  std::uint8_t out[4] = {};
  ASSERT_EQ(f.program(0, a, 4), Status::kOk);
  ASSERT_EQ(f.program(0, b, 4), Status::kOk);  // only clears bits
  ASSERT_EQ(f.read(0, out, 4), Status::kOk);
  EXPECT_EQ(out[0], 0x30);
  EXPECT_EQ(out[1], 0x0F);
  EXPECT_EQ(out[2], 0x55);
  EXPECT_EQ(out[3], 0x00);
  EXPECT_EQ(f.program(30, a, 4), Status::kInvalidArgument);  // crosses a page
  EXPECT_EQ(f.program(1022, a, 4), Status::kInvalidArgument);
  EXPECT_EQ(f.erase(100), Status::kInvalidArgument);  // not aligned
  ASSERT_EQ(f.erase(0), Status::kOk);
  ASSERT_EQ(f.read(0, out, 4), Status::kOk);
  EXPECT_EQ(out[0], 0xFF);
  EXPECT_EQ(out[3], 0xFF);
}

// Counts how many byte operations one save takes (the cut points to try).
std::uint32_t save_cost(const Flash& start, const CalibrationRecord& r) {
  static Flash f;
  f = start;
  const std::uint32_t before = f.byte_operations();
  RecordStore store(f);
  EXPECT_EQ(store.save(r), Status::kOk);
  return f.byte_operations() - before;
}

// For every cut point of a save of `next` over a flash holding `old_id` as the newest record:
// afterwards the store reads old_id or next's id, and a further save succeeds.
void power_cut_everywhere(const Flash& start, std::uint32_t old_id, const CalibrationRecord& next,
                          int* old_seen, int* new_seen) {
  const std::uint32_t cost = save_cost(start, next);
  ASSERT_GT(cost, 1024u);  // the erase and the program
  static Flash f;
  for (std::uint32_t cut = 0; cut <= cost; ++cut) {
    f = start;
    f.cut_power_after(cut);
    RecordStore store(f);
    const Status s = store.save(next);
    if (cut < cost) {
      ASSERT_EQ(s, Status::kStorageError) << cut;
      ASSERT_FALSE(f.powered());
    } else {
      ASSERT_EQ(s, Status::kOk);
    }
    f.power_on();  // reboot
    RecordStore rebooted(f);
    CalibrationRecord out;
    ASSERT_EQ(rebooted.load(out), Status::kOk) << "cut at byte operation " << cut;
    ASSERT_TRUE(out.device_id == old_id || out.device_id == next.device_id) << cut;
    if (out.device_id == old_id)
      ++*old_seen;
    else
      ++*new_seen;
    // The new record, once readable, stays the newest; and the next save works.
    const CalibrationRecord after = record(900 + (cut % 7));
    ASSERT_EQ(rebooted.save(after), Status::kOk) << cut;
    ASSERT_EQ(rebooted.load(out), Status::kOk);
    ASSERT_EQ(out.device_id, after.device_id);
  }
}

TEST(RecordStore, PowerCutAtEveryByteLeavesOldOrNew) {
  static Flash one, two;
  one = Flash();
  RecordStore s1(one);
  ASSERT_EQ(s1.save(record(1)), Status::kOk);  // one slot used, the other erased
  two = one;
  RecordStore s2(two);
  ASSERT_EQ(s2.save(record(2, false)), Status::kOk);  // both used, a short record newest
  int cases = 0;
  int old_seen = 0, new_seen = 0;
  power_cut_everywhere(one, 1, record(10), &old_seen, &new_seen);
  power_cut_everywhere(two, 2, record(20), &old_seen, &new_seen);
  power_cut_everywhere(two, 2, record(21, false), &old_seen, &new_seen);
  cases = old_seen + new_seen;
  std::printf("%d power cuts: old record read after %d, new after %d\n", cases, old_seen, new_seen);
  EXPECT_GT(cases, 3000);
  // The new record is readable only once its commit header is complete: the last 8 byte
  // operations of the save (and the save's own end) at most.
  EXPECT_LE(new_seen, 3 * 8 + 3);
  EXPECT_GE(new_seen, 3);
}

}  // namespace
}  // namespace imucal
