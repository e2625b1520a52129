// Schema of the SQLite backend: numbered migrations, PRAGMA user_version holding how many have
// been applied. A migration is never edited once released; a change of schema is a new one
// appended to the list (and a fixture of the schema before it, tests/fixtures/schema/).
#pragma once

#include <sqlite3.h>

namespace km::server::sqlite {

// The schema version this program writes (the number of migrations).
int SchemaVersion();

// Brings the database from its user_version to SchemaVersion(), each migration in its own
// transaction. A database newer than this program is refused (StorageError), untouched.
void Migrate(sqlite3* db);

}  // namespace km::server::sqlite
