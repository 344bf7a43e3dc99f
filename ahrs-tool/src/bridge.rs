//! `ahrs-tool bridge`: the device's sentences onto the network, for chart software (OpenCPN),
//! Signal K servers and ROV stations on the topside network (`docs/marine.md`).
//!
//! Every line read from the serial port whose checksum verifies is sent as one UDP datagram
//! (`--udp host[:port]`, default port 10110, the usual NMEA port; a broadcast address works)
//! and written to every client of the TCP server (`--tcp addr[:port]`). Lines a TCP client
//! sends go to the device: a sentence (`$...*hh`) as it is, a sentence without checksum with
//! its checksum added, and anything else as a command body (`VER`, `SENT,HDT,1`) wrapped as
//! `$PINAC,<body>*hh`, as `ahrs-tool send` does; the replies come back on the same stream.

use std::{
    io::{BufRead, BufReader, Read, Write},
    net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs, UdpSocket},
    sync::{Arc, Mutex},
    thread,
    time::{Duration, Instant},
};

use inemo_ahrs::nmea;
use serialport::SerialPort;

use crate::link::{command_line, Link};

/// The usual NMEA 0183 network port.
pub const NMEA_PORT: u16 = 10110;
/// A TCP client that cannot take a line within this time is dropped.
const CLIENT_WRITE_TIMEOUT: Duration = Duration::from_secs(2);
/// Longest line taken from a TCP client, bytes (a sentence is at most 82).
const MAX_CLIENT_LINE: usize = 256;

/// `host[:port]` (port 10110 when none is given) to socket addresses.
pub fn resolve(addr: &str) -> Result<Vec<SocketAddr>, String> {
    let direct = addr.to_socket_addrs().map(Iterator::collect::<Vec<_>>);
    let found = match direct {
        Ok(a) if !a.is_empty() => a,
        _ => {
            let host = addr.trim_start_matches('[').trim_end_matches(']');
            (host, NMEA_PORT)
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

type Clients = Arc<Mutex<Vec<TcpStream>>>;
type Serial = Arc<Mutex<Box<dyn SerialPort>>>;

/// One TCP client: its lines to the device until it hangs up.
fn serve_client(stream: TcpStream, serial: Serial) {
    let peer = stream.peer_addr().map(|a| a.to_string()).unwrap_or_default();
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
            if port.write_all(out.as_bytes()).and_then(|()| port.flush()).is_err() {
                eprintln!("bridge: cannot write to the device");
            }
        }
    }
    eprintln!("bridge: TCP client {peer} left");
}

/// Accept TCP clients: each gets the stream and its own thread for what it sends.
fn accept(listener: TcpListener, clients: Clients, serial: Serial) {
    for stream in listener.incoming().flatten() {
        let peer = stream.peer_addr().map(|a| a.to_string()).unwrap_or_default();
        let Ok(reader) = stream.try_clone() else { continue };
        let _ = stream.set_write_timeout(Some(CLIENT_WRITE_TIMEOUT));
        let _ = stream.set_nodelay(true);
        eprintln!("bridge: TCP client {peer}");
        clients.lock().unwrap_or_else(|e| e.into_inner()).push(stream);
        let serial = Arc::clone(&serial);
        thread::spawn(move || serve_client(reader, serial));
    }
}

/// Run the bridge until `stop` says so (Ctrl-C, or the end of `seconds`).
pub fn run(
    port: &str,
    udp: Option<&str>,
    tcp: Option<&str>,
    seconds: Option<f64>,
    stop: &dyn Fn() -> bool,
) -> Result<(), String> {
    if udp.is_none() && tcp.is_none() {
        return Err("nothing to bridge to: give --udp and/or --tcp".into());
    }
    let mut link = Link::open(port)?;
    let serial: Serial = Arc::new(Mutex::new(link.writer().map_err(|e| e.to_string())?));
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
    let clients: Clients = Arc::new(Mutex::new(Vec::new()));
    if let Some(a) = tcp {
        let addr = resolve(a)?;
        let listener =
            TcpListener::bind(&addr[..]).map_err(|e| format!("cannot listen on {a}: {e}"))?;
        let local = listener.local_addr().map_err(|e| e.to_string())?;
        eprintln!("bridge: {port} ↔ TCP clients on {local}");
        let (c, s) = (Arc::clone(&clients), Arc::clone(&serial));
        thread::spawn(move || accept(listener, c, s));
    }
    let end = seconds.map(|s| Instant::now() + Duration::from_secs_f64(s.clamp(0.0, 1e6)));
    let (mut sent, mut udp_errors) = (0u64, 0u64);
    while !stop() && end.is_none_or(|e| Instant::now() < e) {
        let deadline = Instant::now() + Duration::from_millis(200);
        let Some((_, line)) = link.next_sentence(deadline).map_err(|e| e.to_string())? else {
            continue;
        };
        let bytes = format!("{line}\r\n");
        if let Some((sock, target)) = &udp {
            if sock.send_to(bytes.as_bytes(), target).is_err() {
                udp_errors += 1;
            }
        }
        let mut list = clients.lock().unwrap_or_else(|e| e.into_inner());
        list.retain_mut(|c| c.write_all(bytes.as_bytes()).is_ok());
        sent += 1;
    }
    eprintln!("bridge: {sent} sentences forwarded, {udp_errors} UDP send errors");
    Ok(())
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

    #[test]
    fn addresses_default_to_port_10110() {
        assert_eq!(resolve("127.0.0.1").unwrap()[0], "127.0.0.1:10110".parse().unwrap());
        assert_eq!(resolve("127.0.0.1:2000").unwrap()[0], "127.0.0.1:2000".parse().unwrap());
        assert_eq!(resolve("[::1]").unwrap()[0], "[::1]:10110".parse().unwrap());
        assert!(resolve("no such host.invalid").is_err());
    }
}
