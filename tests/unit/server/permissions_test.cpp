// The database holds measurements and token hashes: its files are readable by the owner only
// (0600, whatever the umask), and the data directory is 0700.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "analysis/core/errors.h"
#include "server/base/data_dir.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

unsigned Mode(const std::string& path) {
  struct stat st {};
  EXPECT_EQ(::stat(path.c_str(), &st), 0) << path;
  return static_cast<unsigned>(st.st_mode & 07777);
}

// Runs with a permissive umask, as a careless service manager might set.
class PermissionsTest : public test::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    old_umask_ = ::umask(0);
  }
  void TearDown() override {
    ::umask(old_umask_);
    TempDirTest::TearDown();
  }
  mode_t old_umask_ = 0;
};

TEST_F(PermissionsTest, NewDatabaseFilesAreOwnerOnly) {
  const std::string db = Path("kinemetric.db");
  {
    SqliteStorage st(db);
    st.PutToken("0123", "admin", "first");  // a write: the WAL and shared-memory files exist
    EXPECT_TRUE(st.FindTokenRole("0123"));
    EXPECT_EQ(Mode(db), 0600u);
    for (const char* ext : {"-wal", "-shm"}) {
      if (fs::exists(db + ext)) {
        EXPECT_EQ(Mode(db + ext), 0600u) << ext;
      }
    }
    EXPECT_TRUE(fs::exists(db + "-wal"));
  }
  EXPECT_EQ(Mode(db), 0600u);
}

TEST_F(PermissionsTest, AnExistingDatabaseIsTightened) {
  const std::string db = Path("kinemetric.db");
  { SqliteStorage st(db); }
  fs::permissions(db, fs::perms(0666));
  {
    std::ofstream(db + "-wal", std::ios::app);  // left over by an older version
  }
  fs::permissions(db + "-wal", fs::perms(0644));
  SqliteStorage st(db);
  EXPECT_EQ(Mode(db), 0600u);
  EXPECT_EQ(Mode(db + "-wal"), 0600u);
  EXPECT_EQ(st.CountTokens(), 0);
}

TEST_F(PermissionsTest, DataDirIsCreatedOwnerOnlyAndAnExistingOneTightened) {
  const std::string fresh = Path("a/b/var");
  PrepareDataDir(fresh);
  EXPECT_TRUE(fs::is_directory(fresh));
  EXPECT_EQ(Mode(fresh), 0700u);
  PrepareDataDir(fresh);  // again: nothing changes
  EXPECT_EQ(Mode(fresh), 0700u);

  const std::string old = Path("old");
  fs::create_directory(old);
  fs::permissions(old, fs::perms(0777));
  PrepareDataDir(old);
  EXPECT_EQ(Mode(old), 0700u);

  const std::string file = Path("plain-file");
  std::ofstream(file) << "x";
  EXPECT_THROW(PrepareDataDir(file), Error);
  EXPECT_THROW(PrepareDataDir(""), InvalidInput);
}

// Tightening the -wal and -shm files must not release SQLite's own locks (closing any descriptor
// of a file drops this process's POSIX locks on it): another process then still sees the open
// database's hold on its shared memory (the "DMS" byte 128 of the -shm file, SQLite's unix VFS)
// and does not truncate it under the server's mapping.
TEST_F(PermissionsTest, TheOpenDatabaseKeepsItsLockOnTheSharedMemory) {
  const std::string db = Path("kinemetric.db");
  { SqliteStorage st(db); }  // the -wal and -shm files exist from a former run
  SqliteStorage st(db);
  st.PutToken("0123", "admin", "first");
  ASSERT_TRUE(fs::exists(db + "-shm"));
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // another process: would a write lock on the byte be granted?
    const int fd = ::open((db + "-shm").c_str(), O_RDWR);
    struct flock fl {};
    fl.l_type = F_WRLCK;
    fl.l_whence = SEEK_SET;
    fl.l_start = 128;
    fl.l_len = 1;
    const bool held = fd >= 0 && ::fcntl(fd, F_GETLK, &fl) == 0 && fl.l_type == F_RDLCK;
    ::_exit(held ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the server's read lock on the shared memory is gone";
  EXPECT_TRUE(st.FindTokenRole("0123"));
}

}  // namespace
}  // namespace km::server
