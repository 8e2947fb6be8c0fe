// The file-backed flash port (host): NOR semantics on a file, and a record saved by one run of a
// program read back by the next (the file is the device's flash across reboots).
#include <gtest/gtest.h>

#include <cstdio>

#include "file_flash.hpp"
#include "imucal/record_store.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

constexpr FlashGeometry kGeometry{8192, 4096, 256};

CalibrationRecord accel_record(std::uint32_t id) {
  CalibrationRecord r;
  r.device_id = id;
  r.parts = kRecordAccel;
  r.calibration.accel.params << 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 0.1f, 0.2f, 0.3f;
  r.calibration.accel.poses = 12;
  r.calibration.accel.status = Status::kOk;
  return r;
}

TEST(FileFlash, KeepsTheRecordAcrossReopening) {
  const char* path = "test_file_flash.bin";
  std::remove(path);
  {
    FileFlash flash;
    ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
    RecordStore store(flash);
    CalibrationRecord out;
    EXPECT_EQ(store.load(out), Status::kNoRecord);  // created erased
    ASSERT_EQ(store.save(accel_record(1)), Status::kOk);
    ASSERT_EQ(store.save(accel_record(2)), Status::kOk);
  }
  FileFlash flash;
  ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
  RecordStore store(flash);
  CalibrationRecord out;
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 2u);
  EXPECT_EQ(store.slot_status(0), Status::kOk);  // the previous one is still there
  flash.close();
  // A file of another region's size is refused, not overwritten.
  EXPECT_EQ(flash.open(path, FlashGeometry{4096, 4096, 256}), Status::kInvalidArgument);
  std::remove(path);
}

TEST(FileFlash, ProgramOnlyClearsBitsAndChecksItsArguments) {
  const char* path = "test_file_flash_nor.bin";
  std::remove(path);
  FileFlash flash;
  ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
  const std::uint8_t a[2] = {0xF0, 0x0F}, b[2] = {0x3C, 0xFF};
  std::uint8_t out[2] = {};
  ASSERT_EQ(flash.program(10, a, 2), Status::kOk);
  ASSERT_EQ(flash.program(10, b, 2), Status::kOk);
  ASSERT_EQ(flash.read(10, out, 2), Status::kOk);
  EXPECT_EQ(out[0], 0x30);
  EXPECT_EQ(out[1], 0x0F);
  EXPECT_EQ(flash.program(255, a, 2), Status::kInvalidArgument);  // crosses a page
  EXPECT_EQ(flash.read(8191, out, 2), Status::kInvalidArgument);
  EXPECT_EQ(flash.erase(100), Status::kInvalidArgument);
  ASSERT_EQ(flash.erase(0), Status::kOk);
  ASSERT_EQ(flash.read(10, out, 2), Status::kOk);
  EXPECT_EQ(out[0], 0xFF);
  EXPECT_EQ(FileFlash().open("/nonexistent-dir/x.bin", kGeometry), Status::kStorageError);
  flash.close();
  std::remove(path);
}

}  // namespace
}  // namespace imucal
