#!/usr/bin/env python3
"""A minimal HTTP/2 server that answers every gRPC call with INTERNAL.

For tests/cli_exit_codes_test.sh: exit code 1 ("internal error") is what a
client command returns when the server fails a call unexpectedly, and no
real server of ours can be made to do that on purpose. It speaks just enough
HTTP/2 (the preface, SETTINGS and PING acks, a trailers-only response to each
HEADERS frame, HPACK literals without Huffman coding) for gRPC's C core.
Prints its port on stdout, then serves until killed.
"""
import socket, struct, sys, threading
def frame(t, flags, sid, payload=b""):
    return struct.pack(">I", len(payload))[1:] + bytes([t, flags]) + struct.pack(">I", sid) + payload
def lit(name, value):  # literal header field without indexing, new name, no Huffman
    n, v = name.encode(), value.encode()
    assert len(n) < 127 and len(v) < 127
    return b"\x00" + bytes([len(n)]) + n + bytes([len(v)]) + v
def serve(conn):
    buf = b""
    def need(n):
        nonlocal buf
        while len(buf) < n:
            d = conn.recv(65536)
            if not d: raise EOFError
            buf += d
        out, buf = buf[:n], buf[n:]
        return out
    try:
        need(24)
        conn.sendall(frame(4, 0, 0))
        while True:
            h = need(9)
            length = int.from_bytes(h[:3], "big"); t, flags = h[3], h[4]
            sid = int.from_bytes(h[5:9], "big") & 0x7FFFFFFF
            payload = need(length)
            if t == 4 and not flags & 1: conn.sendall(frame(4, 1, 0))
            elif t == 6 and not flags & 1: conn.sendall(frame(6, 1, 0, payload))
            elif t == 1:
                block = b"\x88" + lit("content-type", "application/grpc") + lit("grpc-status", "13") + \
                        lit("grpc-message", "the test server fails every call")
                conn.sendall(frame(1, 0x5, sid, block))
    except (EOFError, OSError):
        pass
    finally:
        conn.close()
s = socket.socket(); s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("127.0.0.1", 0)); s.listen(8)
print(s.getsockname()[1], flush=True)
while True:
    c, _ = s.accept()
    threading.Thread(target=serve, args=(c,), daemon=True).start()
