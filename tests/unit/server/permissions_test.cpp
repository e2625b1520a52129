// The database holds measurements and token hashes: its files are readable by the owner only
// (0600, whatever the umask), and the data directory is 0700.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/types.h>

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

}  // namespace
}  // namespace km::server
