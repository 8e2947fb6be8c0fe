// SPDX-License-Identifier: MIT
/* ports/qemu-mps2/posix_stubs.c: the two POSIX calls GoogleTest references that picolibc's
 * semihosting layer does not provide. Test binaries only; the library never needs them. */
#include <errno.h>
#include <sys/stat.h>
#include <sys/types.h>

int mkdir(const char* path, mode_t mode) {
  (void)path;
  (void)mode;
  errno = ENOSYS;
  return -1;
}

int stat(const char* path, struct stat* st) {
  (void)path;
  (void)st;
  errno = ENOSYS;
  return -1;
}
