#pragma once
// Small POSIX socket helpers of the Jaguar drivers and their simulator: IPv4 addresses only
// (the boards have fixed addresses; no name lookup), descriptors closed on scope exit.

#include <netinet/in.h>

#include <cstdint>
#include <string>

namespace tsc::link {

/// host (dotted IPv4) and port as a sockaddr. Throws std::invalid_argument naming the host.
sockaddr_in Ipv4(const std::string& host, int port);
/// Creates a socket of `type` (SOCK_DGRAM / SOCK_STREAM), non-blocking, close-on-exec.
/// Throws MotorError with errno's text.
int OpenSocket(int type);
/// The local port a bound socket got (for port 0 = ephemeral).
int LocalPort(int fd);
/// Writes all of `bytes` to a pipe/socket without blocking; false when it could not.
bool SendAll(int fd, const void* bytes, size_t size);
void CloseFd(int& fd);
/// Closes a TCP connection so that what was sent still arrives: unread input is drained first,
/// since closing over unread input resets the connection and the peer may then drop the last
/// lines sent (the driver's final stop).
void CloseStream(int& fd);

}  // namespace tsc::link
