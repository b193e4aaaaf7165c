// The maps' durable store (services/mapping/maps_store): a real SQLite file in a fresh folder.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "services/mapping/maps_store/maps_store.h"
#include "tests/support/test_env.h"

namespace epmap::mapping {
namespace {

TEST(MapsStore, KeepsTheNewestSavedMapsAcrossReopening) {
  const auto dir = testing::FreshTempDir("maps-store") / "state";  // made by the store
  CounterSet events;
  {
    MapsStore store(dir, events);
    EXPECT_FALSE(store.Load().has_value());  // nothing saved yet
    EXPECT_FALSE(store.OnDisk().has_value());
    store.Offer(std::string("first\0state", 11), 3);
    store.Flush();
    const auto saved = store.Load();
    ASSERT_TRUE(saved.has_value());
    EXPECT_EQ(saved->bytes, std::string("first\0state", 11));  // bytes, not text
    EXPECT_EQ(saved->key_frames, 3u);
    EXPECT_GT(saved->saved_unix_ns, 0);
    const auto on_disk = store.OnDisk();
    ASSERT_TRUE(on_disk.has_value());
    EXPECT_EQ(on_disk->saved_unix_ns, saved->saved_unix_ns);
    EXPECT_EQ(on_disk->key_frames, 3u);
    EXPECT_EQ(on_disk->bytes, 11u);
    // Offers faster than the disk: the newest wins, none is torn.
    for (int i = 0; i < 50; ++i) store.Offer(std::string(1000 + i, 'a' + i % 26), 10 + i);
  }  // the destructor writes what is pending
  EXPECT_TRUE(std::filesystem::exists(dir / MapsStore::kFileName));
  EXPECT_GE(events.Get("maps_saved"), 2u);
  EXPECT_EQ(events.Get("maps_save_failed"), 0u);
  MapsStore reopened(dir, events);
  const auto saved = reopened.Load();
  ASSERT_TRUE(saved.has_value());
  EXPECT_EQ(saved->key_frames, 59u);
  EXPECT_EQ(saved->bytes, std::string(1049, 'a' + 49 % 26));
  // What a reopened store reports is what the file holds.
  const auto on_disk = reopened.OnDisk();
  ASSERT_TRUE(on_disk.has_value());
  EXPECT_EQ(on_disk->saved_unix_ns, saved->saved_unix_ns);
  EXPECT_EQ(on_disk->key_frames, 59u);
  EXPECT_EQ(on_disk->bytes, 1049u);
}

TEST(MapsStore, ClearForgetsTheSavedAndThePendingMaps) {
  const auto dir = testing::FreshTempDir("maps-store-clear");
  CounterSet events;
  MapsStore store(dir, events);
  store.Offer("old maps", 5);
  store.Flush();
  ASSERT_TRUE(store.Load().has_value());
  store.Offer(std::string(1 << 20, 'x'), 6);  // perhaps still pending: dropped, or deleted
  store.Clear();
  EXPECT_FALSE(store.Load().has_value());
  EXPECT_FALSE(store.OnDisk().has_value());
  store.Flush();
  EXPECT_FALSE(store.Load().has_value());
  store.Offer("new maps", 1);  // and saving goes on
  store.Flush();
  ASSERT_TRUE(store.Load().has_value());
  EXPECT_EQ(store.Load()->bytes, "new maps");
}

TEST(MapsStore, AFolderThatCannotBeMadeIsAClearError) {
  const auto dir = testing::FreshTempDir("maps-store-bad");
  std::ofstream(dir / "file") << "not a folder";
  CounterSet events;
  try {
    MapsStore store(dir / "file" / "state", events);
    FAIL() << "a folder under a file must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create"), std::string::npos) << e.what();
  }
}

// A maps.sqlite3 that is not a database (another program's file, a broken disk) is refused
// with its name and the reason; epmapd then maps in memory (maps_store_unavailable).
TEST(MapsStore, AFileThatIsNotADatabaseIsAClearError) {
  const auto dir = testing::FreshTempDir("maps-store-junk");
  std::ofstream(dir / MapsStore::kFileName) << std::string(5000, '?');
  CounterSet events;
  try {
    MapsStore store(dir, events);
    FAIL() << "a file that is not a database must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("maps.sqlite3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a database"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace epmap::mapping
