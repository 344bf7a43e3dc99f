//! `ahrs-tool bridge`: the device's sentences onto the network, for chart software (OpenCPN),
//! Signal K servers and ROV stations on the topside network (`docs/marine.md`).
//!
//! Every line read from the serial port whose checksum verifies is sent as one UDP datagram
//! (`--udp host[:port]`, default port 10110, the usual NMEA port; a broadcast address works)
//! and written to every client of the TCP server (`--tcp addr[:port]`). Lines a TCP client
//! sends go to the device: a sentence (`$...*hh`) as it is, a sentence without checksum with
//! its checksum added, and anything else as a command body (`VER`, `SENT,HDT,1`) wrapped as
//! `$PINAC,<body>*hh`, as `ahrs-tool send` does; the replies come back on the same stream.
//!
//! No client can stall the others or the device (issue #38 point 3): each TCP client has its
//! own writer thread and a queue of [`CLIENT_QUEUE`] lines. The serial reader only offers each
//! line to the queues and never waits; a client whose queue is full (it has not read for that
//! many lines, its socket buffers full) is dropped: its socket is shut down, which ends its
//! reader too, and stderr names it. A client that goes away is removed the same way.
//!
//! The bridge outlives the device (issue #38 point 4): when the port fails (the device
//! unplugged, its emulator killed), stderr names the port and the reason, the clients stay
//! connected, and the port is opened again every [`RETRY_MIN`] to [`RETRY_MAX`] (doubling)
//! until it answers; lines the clients send meanwhile are dropped (said once). At the end
//! (Ctrl-C, `--seconds`) it prints what it did: lines forwarded, clients served and dropped,
//! reconnections.

use std::{
    io::{BufRead, BufReader, Read, Write},
    net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs, UdpSocket},
    sync::{
        atomic::{AtomicUsize, Ordering},
        mpsc::{sync_channel, SyncSender, TrySendError},
        Arc, Mutex,
    },
    thread,
    time::{Duration, Instant},
};

use inemo_ahrs::nmea;
use serialport::SerialPort;

use crate::link::{command_line, Link};
use crate::signalk;

/// The usual NMEA 0183 network port.
pub const NMEA_PORT: u16 = 10110;
/// A TCP client whose socket takes nothing for this long is dropped (its writer gives up).
const CLIENT_WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Lines waiting for one TCP client: about 5 s of the device's default output (10 Hz, two
/// sentences a cycle), beyond what its socket buffers hold. Full: the client is dropped.
pub const CLIENT_QUEUE: usize = 100;
/// Longest line taken from a TCP client, bytes (a sentence is at most 82).
const MAX_CLIENT_LINE: usize = 256;
/// First wait before opening a lost port again; it doubles up to [`RETRY_MAX`].
pub const RETRY_MIN: Duration = Duration::from_millis(250);
/// Longest wait between two attempts to open a lost port.
pub const RETRY_MAX: Duration = Duration::from_secs(5);

/// Where the bridge sends the device's output.
pub struct Outputs<'a> {
    /// Every sentence as a UDP datagram to `host[:port]`.
    pub udp: Option<&'a str>,
    /// A TCP server on `addr[:port]`.
    pub tcp: Option<&'a str>,
    /// Signal K deltas (`signalk`) to a server's UDP input on `host[:port]`.
    pub signalk: Option<&'a str>,
}

/// A Signal K server's UDP input port when none is given (the port its own Signal K TCP stream
/// uses by default).
pub const SIGNALK_PORT: u16 = 8375;

/// `host[:port]` (port 10110 when none is given) to socket addresses.
pub fn resolve(addr: &str) -> Result<Vec<SocketAddr>, String> {
    resolve_with(addr, NMEA_PORT)
}

/// `host[:port]`, `port` when none is given.
fn resolve_with(addr: &str, port: u16) -> Result<Vec<SocketAddr>, String> {
    let direct = addr.to_socket_addrs().map(Iterator::collect::<Vec<_>>);
    let found = match direct {
        Ok(a) if !a.is_empty() => a,
        _ => {
            let host = addr.trim_start_matches('[').trim_end_matches(']');
            (host, port)
                .to_socket_addrs()
                .map_err(|e| format!("cannot resolve {addr}: {e}"))?
                .collect()
        }
    };
    if found.is_empty() {
        return Err(format!("cannot resolve {addr}"));
    }
    Ok(found)
}

/// What a TCP client's line becomes on the serial port (`None`: an empty line).
pub fn to_device(line: &str) -> Option<String> {
    let line = line.trim();
    if line.is_empty() {
        return None;
    }
    Some(match line.strip_prefix('$') {
        Some(_) if line.contains('*') => format!("{line}\r\n"),
        Some(body) => format!("${body}*{:02X}\r\n", nmea::checksum(body.as_bytes())),
        None => command_line(line),
    })
}

/// One TCP client as the serial reader sees it: the queue to its writer, and the socket, to
/// shut it down.
struct Client {
    peer: String,
    queue: SyncSender<Arc<[u8]>>,
    socket: TcpStream,
}

type Clients = Arc<Mutex<Vec<Client>>>;
/// The device's port for the clients' lines; `None` while it is lost.
type Serial = Arc<Mutex<Option<Box<dyn SerialPort>>>>;

/// One TCP client (`peer`, its address as accepted: a client that resets at once has none to
/// ask for later): its lines to the device until it hangs up.
fn serve_client(stream: TcpStream, serial: Serial, peer: String) {
    let mut reader = BufReader::new(stream);
    let mut line = Vec::new();
    loop {
        line.clear();
        // At most MAX_CLIENT_LINE bytes per line: a client sending no line end is cut.
        match (&mut reader).take(MAX_CLIENT_LINE as u64).read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => break,
            Ok(_) => {}
        }
        let text = String::from_utf8_lossy(&line);
        if let Some(out) = to_device(&text) {
            let mut port = serial.lock().unwrap_or_else(|e| e.into_inner());
            match port.as_mut() {
                Some(p) => {
                    if p.write_all(out.as_bytes()).and_then(|()| p.flush()).is_err() {
                        eprintln!("bridge: cannot write to the device");
                    }
                }
                None => eprintln!("bridge: {peer}'s line dropped: the device is not connected"),
            }
        }
    }
    eprintln!("bridge: TCP client {peer} left");
}

/// One TCP client's writer: the lines of its queue to its socket, until the queue closes or a
/// write fails (then the socket is shut down, which ends the client's reader as well).
fn write_client(mut stream: TcpStream, lines: std::sync::mpsc::Receiver<Arc<[u8]>>, peer: String) {
    for line in lines {
        if let Err(e) = stream.write_all(&line) {
            match e.kind() {
                // The write timeout (EAGAIN on Linux): the client stopped reading.
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => eprintln!(
                    "bridge: TCP client {peer} dropped: its socket took nothing for {} s",
                    CLIENT_WRITE_TIMEOUT.as_secs()
                ),
                _ => eprintln!("bridge: TCP client {peer} dropped: {e}"),
            }
            let _ = stream.shutdown(Shutdown::Both);
            return;
        }
    }
}

/// Accept TCP clients: each gets its queue, a writer thread and a reader thread; `served`
/// counts them.
fn accept(listener: TcpListener, clients: Clients, serial: Serial, served: Arc<AtomicUsize>) {
    loop {
        let Ok((stream, peer)) = next_client(&listener) else {
            // Out of file descriptors, say: try again shortly rather than spin.
            thread::sleep(Duration::from_millis(50));
            continue;
        };
        served.fetch_add(1, Ordering::Relaxed);
        let (Ok(reader), Ok(writer)) = (stream.try_clone(), stream.try_clone()) else { continue };
        let _ = stream.set_write_timeout(Some(CLIENT_WRITE_TIMEOUT));
        let _ = stream.set_nodelay(true);
        eprintln!("bridge: TCP client {peer}");
        let (queue, lines) = sync_channel(CLIENT_QUEUE);
        let p = peer.clone();
        thread::spawn(move || write_client(writer, lines, p));
        clients.lock().unwrap_or_else(|e| e.into_inner()).push(Client {
            peer: peer.clone(),
            queue,
            socket: stream,
        });
        let serial = Arc::clone(&serial);
        thread::spawn(move || serve_client(reader, serial, peer));
    }
}

/// The next TCP client and its name: the address `accept` itself returns, which a client that
/// has already reset still has (asking the socket for its peer then fails with ENOTCONN, and the
/// log named nobody: issue #38 point 8).
fn next_client(listener: &TcpListener) -> std::io::Result<(TcpStream, String)> {
    listener.accept().map(|(stream, addr)| (stream, addr.to_string()))
}

/// Offers `line` to every client's queue without waiting: a client whose queue is full is
/// dropped (its socket shut down, its name on stderr), one whose writer has ended removed.
/// Returns how many were dropped for a full queue.
fn offer(clients: &mut Vec<Client>, line: &Arc<[u8]>) -> usize {
    let mut dropped = 0;
    clients.retain(|c| match c.queue.try_send(Arc::clone(line)) {
        Ok(()) => true,
        Err(TrySendError::Full(_)) => {
            eprintln!(
                "bridge: TCP client {} dropped: it has not read its last {CLIENT_QUEUE} lines",
                c.peer
            );
            let _ = c.socket.shutdown(Shutdown::Both);
            dropped += 1;
            false
        }
        Err(TrySendError::Disconnected(_)) => false,
    });
    dropped
}

/// Run the bridge until `stop` says so (Ctrl-C, or the end of `seconds`).
pub fn run(
    port: &str,
    to: Outputs,
    seconds: Option<f64>,
    stop: &dyn Fn() -> bool,
) -> Result<(), String> {
    let Outputs { udp, tcp, signalk } = to;
    if udp.is_none() && tcp.is_none() && signalk.is_none() {
        return Err("nothing to bridge to: give --udp, --tcp and/or --signalk".into());
    }
    let mut link = Link::open(port)?;
    let serial: Serial = Arc::new(Mutex::new(Some(link.writer().map_err(|e| e.to_string())?)));
    let served = Arc::new(AtomicUsize::new(0));
    let udp = match udp {
        Some(a) => {
            let target = resolve(a)?[0];
            let bind: SocketAddr =
                if target.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
            let sock = UdpSocket::bind(bind).map_err(|e| format!("UDP socket: {e}"))?;
            // A broadcast address (192.168.1.255) needs the permission; harmless otherwise.
            let _ = sock.set_broadcast(true);
            eprintln!("bridge: {port} → UDP {target}");
            Some((sock, target))
        }
        None => None,
    };
    let signalk = match signalk {
        Some(a) => {
            let target = resolve_with(a, SIGNALK_PORT)?[0];
            let bind: SocketAddr =
                if target.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
            let sock = UdpSocket::bind(bind).map_err(|e| format!("UDP socket: {e}"))?;
            eprintln!("bridge: {port} → Signal K deltas to UDP {target}");
            Some((sock, target))
        }
        None => None,
    };
    let mut meta_sent: Option<Instant> = None;
    let clients: Clients = Arc::new(Mutex::new(Vec::new()));
    if let Some(a) = tcp {
        let addr = resolve(a)?;
        let listener =
            TcpListener::bind(&addr[..]).map_err(|e| format!("cannot listen on {a}: {e}"))?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        eprintln!("bridge: {port} ↔ TCP clients on {local}");
        let (c, s, n) = (Arc::clone(&clients), Arc::clone(&serial), Arc::clone(&served));
        thread::spawn(move || accept(listener, c, s, n));
    }
    let end = seconds.map(|s| Instant::now() + Duration::from_secs_f64(s.clamp(0.0, 1e6)));
    let running = || !stop() && end.is_none_or(|e| Instant::now() < e);
    let (mut sent, mut udp_errors, mut slow, mut reconnections) = (0u64, 0u64, 0usize, 0usize);
    while running() {
        let deadline = Instant::now() + Duration::from_millis(200);
        let line = match link.next_sentence(deadline) {
            Ok(Some((_, line))) => line,
            Ok(None) => continue,
            Err(e) => {
                eprintln!("bridge: {port}: {e}: the device is gone; clients kept, reconnecting");
                *serial.lock().unwrap_or_else(|e| e.into_inner()) = None;
                match reconnect(port, &running) {
                    Some(l) => {
                        link = l;
                        let w = link.writer().ok();
                        *serial.lock().unwrap_or_else(|e| e.into_inner()) = w;
                        reconnections += 1;
                        eprintln!("bridge: {port} is back");
                        continue;
                    }
                    None => break,
                }
            }
        };
        let bytes: Arc<[u8]> = format!("{line}\r\n").into_bytes().into();
        if let Some((sock, target)) = &udp {
            if sock.send_to(&bytes, target).is_err() {
                udp_errors += 1;
            }
        }
        slow += offer(&mut clients.lock().unwrap_or_else(|e| e.into_inner()), &bytes);
        if let Some((sock, target)) = &signalk {
            let mut send = |v: serde_json::Value| {
                if sock.send_to(format!("{v}\n").as_bytes(), target).is_err() {
                    udp_errors += 1;
                }
            };
            if meta_sent.is_none_or(|t| t.elapsed() >= signalk::META_EVERY) {
                send(signalk::meta());
                meta_sent = Some(Instant::now());
            }
            if let Some(d) = nmea::verify(line.as_bytes()).ok().and_then(signalk::delta) {
                send(d);
            }
        }
        sent += 1;
    }
    eprintln!(
        "bridge: {sent} sentences forwarded, {} TCP clients served, {slow} dropped for not \
         reading, {reconnections} reconnections to {port}, {udp_errors} UDP send errors",
        served.load(Ordering::Relaxed)
    );
    Ok(())
}

/// Open `port` again after it failed, waiting [`RETRY_MIN`], doubling up to [`RETRY_MAX`],
/// while `running`; each failure named once per wait length. `None`: stopped first.
fn reconnect(port: &str, running: &dyn Fn() -> bool) -> Option<Link> {
    let mut wait = RETRY_MIN;
    let mut said = Duration::ZERO;
    loop {
        let until = Instant::now() + wait;
        while Instant::now() < until {
            if !running() {
                return None;
            }
            thread::sleep(Duration::from_millis(50));
        }
        match Link::open(port) {
            Ok(l) => return Some(l),
            Err(e) => {
                if said != wait {
                    eprintln!("bridge: {e}; trying again every {:.2} s", wait.as_secs_f64());
                    said = wait;
                }
                wait = (wait * 2).min(RETRY_MAX);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn client_lines_become_device_lines() {
        assert_eq!(to_device("VER\n").as_deref(), Some("$PINAC,VER*38\r\n"));
        assert_eq!(to_device("$PINAC,VER\r\n").as_deref(), Some("$PINAC,VER*38\r\n"));
        assert_eq!(to_device("$PINAC,VER*38\r\n").as_deref(), Some("$PINAC,VER*38\r\n"));
        // A wrong checksum goes as typed: the device answers ERR,?,checksum.
        assert_eq!(to_device("$PINAC,VER*00").as_deref(), Some("$PINAC,VER*00\r\n"));
        assert_eq!(to_device(" \r\n"), None);
    }

    /// Issue #38 point 3: three clients that never read and one that does, against the real
    /// accept loop, writer threads and [`offer`], 1 KB lines offered at about 2 MB/s for at
    /// least 3 s and until the silent clients' socket buffers and queues are full (at most
    /// 30 s: a loaded machine offers fewer). The offering never waits (no call over 50 ms), the
    /// reading client gets every line without a gap over 0.2 s while they are offered, and the
    /// three silent ones are dropped and see their connection closed.
    #[test]
    fn clients_that_do_not_read_are_dropped_and_stall_nobody() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let clients: Clients = Arc::new(Mutex::new(Vec::new()));
        let (c, serial) = (Arc::clone(&clients), Arc::new(Mutex::new(Some(null_port()))));
        let served = Arc::new(AtomicUsize::new(0));
        thread::spawn(move || accept(listener, c, serial, served));
        let silent: Vec<TcpStream> = (0..3).map(|_| TcpStream::connect(addr).unwrap()).collect();
        let reader = TcpStream::connect(addr).unwrap();
        while clients.lock().unwrap().len() < 4 {
            thread::sleep(Duration::from_millis(5));
        }
        let line: Arc<[u8]> = [b"$PINAH,".as_slice(), &[b'0'; 1017], b"\n"].concat().into();
        // The reader counts lines and the longest wait between two reads while lines are
        // offered; once they stop it drains what is left.
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let st = Arc::clone(&stop);
        let got = thread::spawn(move || {
            let (mut r, mut buf, mut n, mut worst, mut last) =
                (reader, vec![0u8; 65536], 0usize, Duration::ZERO, Instant::now());
            r.set_read_timeout(Some(Duration::from_millis(500))).unwrap();
            loop {
                let offering = !st.load(Ordering::SeqCst);
                match r.read(&mut buf) {
                    Ok(0) => break,
                    Ok(k) => n += buf[..k].iter().filter(|&&b| b == b'\n').count(),
                    // Nothing for 0.5 s: drained if the offering has ended meanwhile.
                    Err(_) if st.load(Ordering::SeqCst) => break,
                    Err(_) => {}
                }
                if offering {
                    worst = worst.max(last.elapsed());
                }
                last = Instant::now();
            }
            (n, worst)
        });
        // At least 3 s, and until the three are dropped (how fast their socket buffers fill
        // depends on the machine's load: at most 30 s).
        let (mut dropped, mut slowest, mut offered) = (0, Duration::ZERO, 0usize);
        let start = Instant::now();
        while (start.elapsed() < Duration::from_secs(3) || dropped < 3)
            && start.elapsed() < Duration::from_secs(30)
        {
            let t = Instant::now();
            dropped += offer(&mut clients.lock().unwrap(), &line);
            slowest = slowest.max(t.elapsed());
            offered += 1;
            // About 2 MB/s: faster than the silent sockets' buffers take, slower than loopback.
            thread::sleep(Duration::from_micros(500));
        }
        stop.store(true, Ordering::SeqCst);
        let (received, worst_gap) = got.join().unwrap();
        assert_eq!(dropped, 3, "{offered} lines offered");
        assert_eq!(clients.lock().unwrap().len(), 1);
        assert!(slowest < Duration::from_millis(50), "an offer took {slowest:?}");
        assert!(received >= offered - CLIENT_QUEUE, "{received} of {offered}");
        assert!(worst_gap < Duration::from_millis(200), "gap {worst_gap:?}");
        // The dropped ones were shut down: after what was buffered, their reads end.
        for mut s in silent {
            s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let mut sink = vec![0u8; 1 << 20];
            let closed = loop {
                match s.read(&mut sink) {
                    Ok(0) => break true,
                    Ok(_) => continue,
                    Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => break true,
                    Err(_) => break false,
                }
            };
            assert!(closed, "a dropped client's connection is still open");
        }
    }

    /// Issue #38 point 8: a client that resets before the bridge gets to it (SO_LINGER 0, then
    /// closed: the kernel answers with RST) is still named by the address it connected from.
    #[test]
    fn a_client_that_resets_at_once_is_named() {
        use nix::sys::socket::{setsockopt, sockopt::Linger};
        use std::os::fd::AsRawFd;
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let client = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
        let from = client.local_addr().unwrap().to_string();
        setsockopt(client.as_raw_fd(), Linger, &libc::linger { l_onoff: 1, l_linger: 0 }).unwrap();
        drop(client);
        thread::sleep(Duration::from_millis(100));
        let (stream, name) = next_client(&listener).unwrap();
        // The reset arrived: the socket itself no longer knows its peer.
        assert!(stream.peer_addr().is_err(), "the client did not reset");
        assert_eq!(name, from);
    }

    /// A serial port that takes every byte (the clients here send nothing).
    fn null_port() -> Box<dyn SerialPort> {
        let (master, _slave) = serialport::TTYPort::pair().unwrap();
        Box::new(master)
    }

    #[test]
    fn addresses_default_to_port_10110() {
        assert_eq!(resolve("127.0.0.1").unwrap()[0], "127.0.0.1:10110".parse().unwrap());
        assert_eq!(resolve("127.0.0.1:2000").unwrap()[0], "127.0.0.1:2000".parse().unwrap());
        assert_eq!(resolve("[::1]").unwrap()[0], "[::1]:10110".parse().unwrap());
        assert!(resolve("no such host.invalid").is_err());
    }
}
