// Schema of the PostgreSQL backend: the SQLite backend's tables
// (server/storage/sqlite/sqlite_migrations.cpp) in PostgreSQL types, numbered the same way. Table
// kinemetric_schema holds how many migrations have been applied; they run under an advisory lock,
// so instances starting at once migrate once. A migration is never edited once released; a change
// of schema is a new one appended here and to server/storage/sqlite/sqlite_migrations.cpp with the
// same number.
#pragma once

namespace km::server::pg {

class Conn;

// The schema version this program writes (the number of migrations).
int SchemaVersion();

// Brings the database to version `target` (SchemaVersion(); an older one only in tests of a
// migration), each migration in its own transaction, holding the advisory lock meanwhile. A
// database newer than this program is refused (StorageError), untouched.
void Migrate(Conn& conn, int target = SchemaVersion());

}  // namespace km::server::pg
