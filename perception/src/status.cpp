#include "depowder/perception/status.hpp"

namespace depowder::perception {

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::kOk:
      return "ok";
    case FrameStatus::kSizeMismatch:
      return "size_mismatch";
    case FrameStatus::kBadHeader:
      return "bad_header";
    case FrameStatus::kNoValidReturns:
      return "no_valid_returns";
    case FrameStatus::kLate:
      return "late";
    case FrameStatus::kDuplicate:
      return "duplicate";
    case FrameStatus::kAhead:
      return "ahead";
    case FrameStatus::kUnreadable:
      return "unreadable";
    case FrameStatus::kCount:
      break;
  }
  return "unknown";
}

}  // namespace depowder::perception
