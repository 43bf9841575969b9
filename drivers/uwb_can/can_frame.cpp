#include "drivers/uwb_can/can_frame.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <cstdio>

namespace ips::uwb_can {

bool valid_fd_len(unsigned len) {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 ||
         len == 64;
}

namespace {

struct Bit {
  uint32_t mask;
  const char* name;
};

// Error classes of the CAN id (linux/can/error.h), in the kernel's order.
constexpr Bit kErrorClasses[] = {
    {CAN_ERR_TX_TIMEOUT, "tx-timeout"},
    {CAN_ERR_LOSTARB, "lost-arbitration"},
    {CAN_ERR_CRTL, "controller-problem"},
    {CAN_ERR_PROT, "protocol-violation"},
    {CAN_ERR_TRX, "transceiver-status"},
    {CAN_ERR_ACK, "no-acknowledgement-on-tx"},
    {CAN_ERR_BUSOFF, "bus-off"},
    {CAN_ERR_BUSERROR, "bus-error"},
    {CAN_ERR_RESTARTED, "restarted-after-bus-off"},
    {0x200U, "error-counters"},  // CAN_ERR_CNT (Linux 5.19): counters in data[6], data[7]
};

// Controller problems in data[1] of a CAN_ERR_CRTL error frame.
constexpr Bit kControllerProblems[] = {
    {CAN_ERR_CRTL_RX_OVERFLOW, "rx-overflow"},
    {CAN_ERR_CRTL_TX_OVERFLOW, "tx-overflow"},
    {CAN_ERR_CRTL_RX_WARNING, "rx-error-warning"},
    {CAN_ERR_CRTL_TX_WARNING, "tx-error-warning"},
    {CAN_ERR_CRTL_RX_PASSIVE, "rx-error-passive"},
    {CAN_ERR_CRTL_TX_PASSIVE, "tx-error-passive"},
    {0x40U, "back-to-error-active"},  // CAN_ERR_CRTL_ACTIVE
};

}  // namespace

std::string describe_error_frame(const CanFrame& frame) {
  std::string out;
  uint32_t known = 0;
  for (const Bit& c : kErrorClasses) {
    known |= c.mask;
    if (!(frame.id & c.mask)) continue;
    if (!out.empty()) out += ", ";
    out += c.name;
    if (c.mask == CAN_ERR_CRTL && frame.len >= 2 && frame.data[1] != 0) {
      std::string problems;
      for (const Bit& p : kControllerProblems)
        if (frame.data[1] & p.mask)
          problems += (problems.empty() ? "" : ", ") + std::string(p.name);
      if (!problems.empty()) out += " (" + problems + ")";
    }
  }
  if (frame.id & ~known) {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%X", static_cast<unsigned>(frame.id & ~known));
    out += (out.empty() ? "" : ", ") + std::string("unknown class ") + hex;
  }
  if (out.empty()) out = "no error class";
  return out;
}

bool error_frame_lost_frames(const CanFrame& frame) {
  return frame.error && (frame.id & CAN_ERR_CRTL) && frame.len >= 2 &&
         (frame.data[1] & CAN_ERR_CRTL_RX_OVERFLOW);
}

}  // namespace ips::uwb_can
