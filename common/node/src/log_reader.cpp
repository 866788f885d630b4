#include "depowder/node/log_reader.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <stdexcept>

namespace depowder::node {

namespace {

constexpr std::array<std::uint8_t, 4> kSync{0xED, 0xA1, 0xDA, 0x01};  // lcm/eventlog.c, big-endian
constexpr std::int64_t kHeader = 4 + 8 + 8 + 4 + 4;  // sync, event number, time, channel and data lengths

std::uint64_t bigEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | p[k];
  return v;
}

}  // namespace

LogReader::LogReader(const std::string& path) : file_(std::fopen(path.c_str(), "rb")), owned_(true) {
  if (file_ == nullptr) throw std::runtime_error("cannot read LCM log '" + path + "'");
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    std::fclose(file_);
    throw std::runtime_error("cannot read LCM log '" + path + "': it is a directory");
  }
  size_ = size();
}

LogReader::LogReader(std::FILE* file) : file_(file) {
  start_ = pos_ = good_end_ = std::max<std::int64_t>(0, ftello(file_));
  size_ = size();
}

LogReader::~LogReader() {
  if (owned_) std::fclose(file_);
}

std::int64_t LogReader::size() {
  const std::int64_t here = ftello(file_);
  if (fseeko(file_, 0, SEEK_END) == 0) size_ = std::max<std::int64_t>(size_, ftello(file_));
  if (here >= 0) fseeko(file_, here, SEEK_SET);
  return size_;
}

bool LogReader::readAt(std::int64_t offset, void* into, std::size_t bytes) {
  if (ftello(file_) != offset && fseeko(file_, offset, SEEK_SET) != 0) return false;
  return bytes == 0 || std::fread(into, 1, bytes, file_) == bytes;
}

void LogReader::skipped(std::int64_t to, bool at_end) {
  if (to <= good_end_) return;
  LogDamage d{good_end_ - start_, to - good_end_, at_end, false};
  std::array<std::uint8_t, 4> head{};
  d.cut_short = at_end && d.bytes >= 4 && readAt(good_end_, head.data(), 4) && head == kSync;
  damage_.push_back(d);
  good_end_ = to;
}

const lcm::LogEvent* LogReader::next() {
  std::vector<std::uint8_t> block;
  std::array<std::uint8_t, kHeader> h{};
  for (;;) {
    // The next sync word at or after pos_: in a whole log, right there.
    std::int64_t at = -1;
    const bool here = readAt(pos_, h.data(), h.size()) && std::equal(kSync.begin(), kSync.end(), h.begin());
    if (here) at = pos_;
    for (std::int64_t from = pos_; at < 0;) {
      if (size_ - from < 4 && size() - from < 4) break;
      block.resize(static_cast<std::size_t>(std::min<std::int64_t>(size_ - from, 1 << 16)));
      if (!readAt(from, block.data(), block.size())) break;
      const auto hit = std::search(block.begin(), block.end(), kSync.begin(), kSync.end());
      if (hit != block.end())
        at = from + (hit - block.begin());
      else
        from += static_cast<std::int64_t>(block.size()) - 3;  // a sync word may straddle two blocks
    }
    if (at < 0) {
      skipped(size(), true);
      return nullptr;
    }
    // Its header, then its channel and data, as lcm/eventlog.c takes them; anything else is
    // damage, and the search goes on from the next byte.
    pos_ = at + 1;
    if (!here && !readAt(at, h.data(), h.size())) continue;
    const auto channel_bytes = static_cast<std::int32_t>(bigEndian(&h[20], 4));
    const auto data_bytes = static_cast<std::int32_t>(bigEndian(&h[24], 4));
    if (channel_bytes <= 0 || channel_bytes >= 1000 || data_bytes < 0) continue;
    const std::int64_t end = at + kHeader + channel_bytes + data_bytes;
    if (end > size_ && end > size()) continue;
    std::string channel(static_cast<std::size_t>(channel_bytes), '\0');
    if (!readAt(at + kHeader, channel.data(), channel.size())) continue;
    if (std::any_of(channel.begin(), channel.end(),
                    [](char c) { return c == '\0' || c == '\x7f' || (c > 0 && c < ' '); }))
      continue;  // no channel name holds a control character: these bytes are not a header
    data_.resize(static_cast<std::size_t>(data_bytes));
    if (!readAt(at + kHeader + channel_bytes, data_.data(), data_.size())) continue;
    // An event cut short and then written after (a logger restarted with --append) claims the
    // next events' bytes: it does not end where the log does or another event begins, and one
    // begins inside it. It is damage, and the search for those events goes on from inside it.
    std::array<std::uint8_t, 4> after{};
    const bool at_log_end = end >= size_ && end >= size();
    if (!at_log_end && !(readAt(end, after.data(), after.size()) && after == kSync) &&
        std::search(data_.begin(), data_.end(), kSync.begin(), kSync.end()) != data_.end())
      continue;

    skipped(at, false);
    good_end_ = pos_ = end;
    ++events_;
    event_.eventnum = static_cast<std::int64_t>(bigEndian(&h[4], 8));
    event_.timestamp = static_cast<std::int64_t>(bigEndian(&h[12], 8));
    event_.channel = std::move(channel);
    event_.datalen = data_bytes;
    event_.data = data_.data();
    return &event_;
  }
}

std::string describe(const LogDamage& d) {
  std::string out = "bytes " + std::to_string(d.offset) + ".." + std::to_string(d.offset + d.bytes - 1) + " (" +
                    std::to_string(d.bytes) + ") ";
  if (d.cut_short)
    return out + "are an event cut short at the end of the log (a recording stopped mid-write?): left out";
  if (d.at_end) return out + "at the end of the log are not an event: left out";
  return out + "are not an event (damage, or another file's bytes): skipped to the next whole event";
}

}  // namespace depowder::node
