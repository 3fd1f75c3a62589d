// Where the sessions are kept: `sqlite:PATH` (embedded, one file) or
// `postgresql://[user[:password]@]host[:port]/dbname[?param=value&...]`
// (also `postgres://`), handed to libpq as a connection URI.
#pragma once

#include <string>
#include <string_view>

#include "dentar/core/result.h"

namespace dentar::store {

struct DbUrl {
  enum class Kind { Sqlite, Postgres };
  Kind kind = Kind::Sqlite;
  std::string path;      // sqlite: the file (":memory:" allowed)
  std::string uri;       // postgres: the URI as given (with any password)
  std::string redacted;  // for messages and logs: the password replaced by ***
  bool has_password = false;  // postgres: a password in the user info or a password= parameter
};

// The command line refuses URLs with a password (it shows in `ps`): the
// message says to use PGPASSWORD or a pgpass file instead. Empty: fine.
std::string password_on_command_line(const DbUrl& url, const std::string& option = "--db");

// Errors name the URL (redacted) and say what form is expected.
Result<DbUrl> parse_db_url(std::string_view text);

}  // namespace dentar::store
