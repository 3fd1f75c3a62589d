// The backend under Store: one connection, text parameters ($1, $2, ... in
// both dialects), text results (NULL = nullopt). Private to store/.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dentar/store/db_url.h"

namespace dentar::store {

using Value = std::optional<std::string>;
using Row = std::vector<Value>;

class Db {
 public:
  virtual ~Db() = default;
  virtual bool postgres() const = 0;
  // Several statements, no parameters, no rows.
  virtual Status exec(const std::string& sql) = 0;
  virtual Result<std::vector<Row>> query(const std::string& sql, const std::vector<Value>& params = {}) = 0;
  // A write transaction: sqlite BEGIN IMMEDIATE (takes the write lock now),
  // postgres BEGIN.
  virtual Status begin_write() = 0;
  Status commit() { return exec("COMMIT"); }
  void rollback() { (void)exec("ROLLBACK"); }
};

// Tells the user (set_lock_wait_notice's callback) that a statement waits
// for another program's lock. Any thread.
void lock_wait_notice(const std::string& text);

// check: PRAGMA quick_check on an existing file (a damaged one is refused).
Result<std::unique_ptr<Db>> open_sqlite(const DbUrl& url, bool create, bool check);
Result<std::unique_ptr<Db>> open_postgres(const DbUrl& url, int connect_timeout_s);

}  // namespace dentar::store
