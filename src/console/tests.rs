//! The two consoles on the host: line assembly per port, reply routing, the fan-out and the
//! USB side's drop policy.

use super::*;
use crate::command::{Device, LineEvent};
use crate::nmea::{checksum, Sentence};
use crate::persist::{self, SimFlash};

/// A finished sentence with `body`.
fn sentence(body: &str) -> Sentence {
    let mut s = Sentence::new();
    s.push_str(body).unwrap();
    s.finish().unwrap();
    s
}

/// `$<body>*hh\r\n`, as a host sends a command.
fn cmd(body: &str) -> Vec<u8> {
    format!("${body}*{:02X}\r\n", checksum(body.as_bytes())).into_bytes()
}

/// The USART's DMA batch, on the host: a buffer of `cap` bytes.
struct VecBatch {
    bytes: Vec<u8>,
    cap: usize,
    dropped: u32,
}

impl VecBatch {
    fn new(cap: usize) -> Self {
        VecBatch { bytes: Vec::new(), cap, dropped: 0 }
    }
    fn text(&self) -> String {
        String::from_utf8(self.bytes.clone()).unwrap()
    }
}

impl UsartBatch for VecBatch {
    fn len(&self) -> usize {
        self.bytes.len()
    }
    fn push(&mut self, part: &[u8]) -> bool {
        if self.bytes.len() + part.len() > self.cap {
            return false;
        }
        self.bytes.extend_from_slice(part);
        true
    }
    fn count_dropped(&mut self) {
        self.dropped += 1;
    }
}

/// Everything waiting in `usb`, as a host reading without limit would get it.
fn read_all<const N: usize>(usb: &mut UsbOut<N>) -> String {
    let mut got = Vec::new();
    let mut chunk = [0u8; 64];
    loop {
        let n = usb.peek(&mut chunk);
        if n == 0 {
            break;
        }
        got.extend_from_slice(&chunk[..n]);
        usb.consume(n);
    }
    String::from_utf8(got).unwrap()
}

fn cycle_sentences() -> [Sentence; 2] {
    [sentence("PINAH,1,2,3"), sentence("HCHDT,10.0,T")]
}

const BIG: usize = 1024;

#[test]
fn routes_reach_their_ports() {
    assert!(Route::Usart.reaches(Port::Usart) && !Route::Usart.reaches(Port::Usb));
    assert!(Route::Usb.reaches(Port::Usb) && !Route::Usb.reaches(Port::Usart));
    assert!(Route::Both.reaches(Port::Usb) && Route::Both.reaches(Port::Usart));
    assert_eq!(Route::from(Port::Usb), Route::Usb);
    assert_eq!(Route::from(Port::Usart), Route::Usart);
}

#[test]
fn sentences_go_to_both_ports_when_usb_is_open() {
    let mut usb = UsbOut::<BIG>::new();
    usb.set_host(true, true);
    let mut replies = Replies::<4>::new();
    let mut batch = VecBatch::new(BIG);
    let s = cycle_sentences();
    assert_eq!(fan_out(Some(&mut batch), s.iter(), &mut replies, 1000, &mut usb), 0);
    let expected = format!("{}{}", s[0].as_str(), s[1].as_str());
    assert_eq!(batch.text(), expected);
    assert_eq!(read_all(&mut usb), expected);
    assert_eq!((usb.dropped_closed, usb.dropped_full), (0, 0));
}

#[test]
fn closed_usb_port_drops_and_counts_and_usart_is_unchanged() {
    let mut usb = UsbOut::<BIG>::new();
    let mut replies = Replies::<4>::new();
    replies.push(sentence("PINAR,OK,VER"), Route::Both);
    let mut batch = VecBatch::new(BIG);
    let s = cycle_sentences();
    fan_out(Some(&mut batch), s.iter(), &mut replies, 1000, &mut usb);
    let usart = batch.text();
    assert!(usart.starts_with(&format!("{}{}$PINAR,OK,VER*", s[0].as_str(), s[1].as_str())));
    assert!(usb.is_empty());
    assert_eq!(usb.dropped_closed, 2);
    assert_eq!(replies.usb_dropped, 1);
    assert_eq!(replies.waiting(Port::Usb), 0, "a closed port's replies do not pile up");
}

#[test]
fn full_usb_queue_does_not_stop_usart_output() {
    // A host opened the port and reads nothing: the queue fills, USART2 goes on.
    let mut usb = UsbOut::<200>::new();
    usb.set_host(true, true);
    let mut replies = Replies::<4>::new();
    let s = cycle_sentences();
    let per_cycle: String = s.iter().map(|x| x.as_str()).collect();
    let mut dropped_full = 0;
    for cycle in 0..20 {
        let mut batch = VecBatch::new(BIG);
        let busy = fan_out(Some(&mut batch), s.iter(), &mut replies, 1000, &mut usb);
        assert_eq!(busy, 0);
        assert_eq!(batch.text(), per_cycle, "cycle {cycle}: USART2 output changed");
        assert_eq!(batch.dropped, 0);
        assert!(usb.len() <= 200);
        dropped_full = usb.dropped_full;
    }
    // What was queued is whole sentences, in order; every other one was counted.
    let got = read_all(&mut usb);
    let queued = got.matches('$').count() as u32;
    assert!(dropped_full > 0 && queued > 0);
    assert_eq!(queued + dropped_full, 40, "sentences that did not fit were counted");
    assert!(got.starts_with(s[0].as_str()));
    assert!(got.ends_with("\r\n"));
    assert_eq!(got.matches('$').count(), got.matches("\r\n").count());
}

#[test]
fn full_usb_queue_keeps_replies_waiting_and_usart_replies_flow() {
    let mut usb = UsbOut::<100>::new();
    usb.set_host(true, true);
    assert_eq!(usb.offer(&[b'x'; 90]), Offer::Queued);
    let mut replies = Replies::<4>::new();
    replies.push(sentence("PINAR,OK,VER,inemo-ahrs,0.1.0"), Route::Both);
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), [].iter(), &mut replies, 1000, &mut usb);
    assert!(batch.text().contains("PINAR,OK,VER"), "USART2 got its copy");
    assert_eq!(replies.waiting(Port::Usb), 1, "the USB copy waits for room");
    assert_eq!(replies.usb_dropped, 0);
    // The host reads; the next cycle sends the reply.
    assert_eq!(read_all(&mut usb).len(), 90);
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), [].iter(), &mut replies, 1000, &mut usb);
    assert_eq!(batch.text(), "");
    assert!(read_all(&mut usb).contains("PINAR,OK,VER"));
    assert_eq!(replies.waiting(Port::Usb), 0);
}

#[test]
fn busy_usart_still_feeds_usb() {
    let mut usb = UsbOut::<BIG>::new();
    usb.set_host(true, true);
    let mut replies = Replies::<4>::new();
    replies.push(sentence("PINAR,OK,A"), Route::Usart);
    let s = cycle_sentences();
    let busy = fan_out(None::<&mut VecBatch>, s.iter(), &mut replies, 1000, &mut usb);
    assert_eq!(busy, 2, "the USART's sentences of this cycle are dropped and counted");
    assert_eq!(replies.waiting(Port::Usart), 1, "the USART's reply waits");
    assert_eq!(read_all(&mut usb), format!("{}{}", s[0].as_str(), s[1].as_str()));
}

#[test]
fn usart_replies_keep_the_byte_budget() {
    let mut usb = UsbOut::<BIG>::new();
    let mut replies = Replies::<4>::new();
    let a = sentence("PINAR,OK,AAAAAAAAAAAAAAAAAAAA");
    let b = sentence("PINAR,OK,BBBBBBBBBBBBBBBBBBBB");
    replies.push(a.clone(), Route::Usart);
    replies.push(b.clone(), Route::Usart);
    let s = [sentence("PINAH,1")];
    let budget = s[0].len() + a.len() + 1;
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), s.iter(), &mut replies, budget, &mut usb);
    assert_eq!(batch.text(), format!("{}{}", s[0].as_str(), a.as_str()));
    assert_eq!(replies.waiting(Port::Usart), 1);
    // An empty batch always takes one reply, whatever the budget.
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), [].iter(), &mut replies, 1, &mut usb);
    assert_eq!(batch.text(), b.as_str());
}

#[test]
fn a_reply_goes_to_the_port_its_command_came_from() {
    let mut usb = UsbOut::<BIG>::new();
    usb.set_host(true, true);
    let mut replies = Replies::<4>::new();
    replies.push(sentence("PINAR,OK,FROM-USB"), Route::Usb);
    replies.push(sentence("PINAR,OK,FROM-USART"), Route::Usart);
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), [].iter(), &mut replies, 1000, &mut usb);
    let usart = batch.text();
    let usb_text = read_all(&mut usb);
    assert!(usart.contains("FROM-USART") && !usart.contains("FROM-USB"), "{usart}");
    assert!(usb_text.contains("FROM-USB") && !usb_text.contains("FROM-USART"), "{usb_text}");
}

#[test]
fn interleaved_partial_lines_on_two_ports_stay_apart() {
    let mut usart = PortLines::new(Port::Usart);
    let mut usb = PortLines::new(Port::Usb);
    let a = cmd("PINAC,VER");
    let b = cmd("PINAC,GET,filter.rate");
    let mut got = Vec::new();
    // Byte by byte, alternating: each port's line arrives whole, tagged with its port.
    for i in 0..a.len().max(b.len()) {
        if let Some(&x) = a.get(i) {
            got.extend(usart.push(x));
        }
        if let Some(&x) = b.get(i) {
            got.extend(usb.push(x));
        }
    }
    assert_eq!(got.len(), 2, "{got:?}");
    let line = |r: &Received| match r.event {
        LineEvent::Line(l) => String::from_utf8(l.as_bytes().to_vec()).unwrap(),
        LineEvent::TooLong => "too long".into(),
    };
    let from_usart = got.iter().find(|r| r.from == Port::Usart).unwrap();
    let from_usb = got.iter().find(|r| r.from == Port::Usb).unwrap();
    assert_eq!(line(from_usart), String::from_utf8(a[..a.len() - 2].to_vec()).unwrap());
    assert_eq!(line(from_usb), String::from_utf8(b[..b.len() - 2].to_vec()).unwrap());
    assert_eq!(from_usart.reply_route(), Route::Usart);
    assert_eq!(from_usb.reply_route(), Route::Usb);
}

#[test]
fn a_command_from_usb_is_answered_on_usb_only() {
    // The whole path as the firmware wires it: port → line → Device → reply queue → fan-out.
    let mut flash = SimFlash::new();
    let mut device = Device::new(&persist::load(&flash), "POR");
    let mut usb_lines = PortLines::new(Port::Usb);
    let mut usart_lines = PortLines::new(Port::Usart);
    let mut replies = Replies::<4>::new();
    let mut usb = UsbOut::<BIG>::new();
    usb.set_host(true, true);
    // Half a USART line first, then a whole USB command, then the rest of the USART line.
    let usart_cmd = cmd("PINAC,GET,filter.rate");
    let (head, tail) = usart_cmd.split_at(8);
    let mut received = Vec::new();
    received.extend(head.iter().filter_map(|&x| usart_lines.push(x)));
    received.extend(cmd("PINAC,VER").iter().filter_map(|&x| usb_lines.push(x)));
    received.extend(tail.iter().filter_map(|&x| usart_lines.push(x)));
    assert_eq!(received.len(), 2);
    for r in &received {
        let response = device.handle(&r.event, &mut flash);
        replies.push(response.reply.unwrap(), r.reply_route());
    }
    let mut batch = VecBatch::new(BIG);
    fan_out(Some(&mut batch), [].iter(), &mut replies, 1000, &mut usb);
    let usart = batch.text();
    let usb_text = read_all(&mut usb);
    assert!(usb_text.starts_with("$PINAR,OK,VER,"), "{usb_text}");
    assert!(!usb_text.contains("filter.rate"), "{usb_text}");
    assert!(usart.contains("OK,GET,filter.rate") && !usart.contains(",VER,"), "{usart}");
}

#[test]
fn losing_the_configuration_discards_what_waits() {
    let mut usb = UsbOut::<64>::new();
    assert_eq!(usb.offer(b"abc"), Offer::Closed);
    usb.set_host(true, true);
    assert_eq!(usb.offer(b"abc"), Offer::Queued);
    // Unplugged, reset or suspended: whatever DTR was.
    usb.set_host(false, true);
    assert!(usb.is_empty());
    assert_eq!(usb.offer(b"xyz"), Offer::Closed);
    usb.set_host(true, true);
    assert_eq!(usb.offer(b"def"), Offer::Queued);
    assert_eq!(read_all(&mut usb), "def");
}

#[test]
fn a_change_of_dtr_discards_what_waits() {
    let mut usb = UsbOut::<64>::new();
    // Configured with DTR off: nothing was armed for an earlier reader.
    assert!(!usb.set_host(true, false));
    assert_eq!(usb.offer(b"old"), Offer::Queued);
    // The same state again keeps it (the USB task reports it on every interrupt).
    assert!(!usb.set_host(true, false));
    assert_eq!(usb.len(), 3);
    // A program opens the port (DTR up): it starts with fresh output, and the packet armed
    // for nobody is to be taken back.
    assert!(usb.set_host(true, true));
    assert!(usb.is_empty());
    assert_eq!(usb.offer(b"new"), Offer::Queued);
    assert!(!usb.set_host(true, true));
    assert_eq!(read_all(&mut usb), "new");
    usb.offer(b"left");
    // It closes the port (DTR down): what it did not read is stale for the next one.
    assert!(usb.set_host(true, false));
    assert!(usb.is_empty());
    // Unplugged: the configuration, the endpoints and what they held are gone anyway.
    assert!(!usb.set_host(false, false));
    assert!(!usb.set_host(false, true));
    // Configured again with DTR already up (a host that opens the port at once).
    assert!(!usb.set_host(true, true));
}

#[test]
fn a_configured_port_without_dtr_gets_the_output() {
    // serialport (ahrs-tool) on Windows opens a port with DTR off.
    let mut usb = UsbOut::<BIG>::new();
    usb.set_host(true, false);
    let mut replies = Replies::<4>::new();
    let s = cycle_sentences();
    fan_out(Some(&mut VecBatch::new(BIG)), s.iter(), &mut replies, 1000, &mut usb);
    assert_eq!(read_all(&mut usb), format!("{}{}", s[0].as_str(), s[1].as_str()));
    assert_eq!(usb.dropped_closed, 0);
}

#[test]
fn the_queue_takes_whole_parts_and_drains_in_order_across_the_wrap() {
    let mut usb = UsbOut::<10>::new();
    usb.set_host(true, true);
    assert_eq!(usb.offer(b"0123456"), Offer::Queued);
    assert_eq!(usb.offer(b"789a"), Offer::Full, "nothing of a part that does not fit");
    assert_eq!(usb.len(), 7);
    // A slow reader: the serial port takes 3 of the 7 bytes.
    let mut chunk = [0u8; 64];
    assert_eq!(usb.peek(&mut chunk), 7);
    assert_eq!(&chunk[..7], b"0123456");
    usb.consume(3);
    assert_eq!(usb.len(), 4);
    assert_eq!(usb.offer(b"789ab"), Offer::Queued, "wraps round the end");
    assert_eq!(usb.free(), 1);
    assert_eq!(read_all(&mut usb), "3456789ab");
    assert!(usb.is_empty());
}

#[test]
fn peek_takes_nothing_and_copies_at_most_its_buffer() {
    let mut usb = UsbOut::<64>::new();
    usb.set_host(true, true);
    usb.offer(b"hello world");
    let mut small = [0u8; 4];
    assert_eq!(usb.peek(&mut small), 4);
    assert_eq!(&small, b"hell");
    assert_eq!(usb.len(), 11, "a serial port that takes nothing leaves everything waiting");
    usb.consume(100);
    assert!(usb.is_empty());
    assert_eq!(usb.peek(&mut small), 0);
}

#[test]
fn reply_queues_drop_per_port() {
    let mut replies = Replies::<2>::new();
    for _ in 0..3 {
        replies.push(sentence("PINAR,OK,X"), Route::Usb);
    }
    assert_eq!((replies.usb_dropped, replies.usart_dropped), (1, 0));
    replies.push(sentence("PINAR,OK,Y"), Route::Usart);
    assert_eq!(replies.waiting(Port::Usart), 1);
    assert_eq!(replies.dropped(), 1);
    // Both ports' drops count: two more for USART2, one fits.
    replies.push(sentence("PINAR,OK,Z"), Route::Usart);
    replies.push(sentence("PINAR,OK,W"), Route::Usart);
    assert_eq!((replies.usb_dropped, replies.usart_dropped), (1, 1));
    assert_eq!(replies.dropped(), 2);
}

/// The queue's state as the USB task and the 10-s log read it, and its exact fit: a part of
/// exactly the free room is queued whole, one byte more is refused (issue #39 point 5: these
/// accessors returning a constant, and `>` as `>=` in `offer`, passed every test before).
#[test]
fn the_queue_reports_its_state_and_takes_an_exact_fit() {
    let mut usb = UsbOut::<8>::new();
    assert!(!usb.is_open() && !usb.dtr() && usb.is_empty() && usb.free() == 8);
    usb.set_host(true, false);
    assert!(usb.is_open() && !usb.dtr());
    usb.set_host(true, true);
    assert!(usb.is_open() && usb.dtr());
    assert_eq!(usb.offer(b"abc"), Offer::Queued);
    assert!(!usb.is_empty() && usb.len() == 3 && usb.free() == 5);
    assert_eq!(usb.offer(b"defghi"), Offer::Full, "one byte more than the room");
    assert_eq!(usb.offer(b"defgh"), Offer::Queued, "exactly the room");
    assert!(usb.free() == 0 && usb.len() == 8);
    assert_eq!(read_all(&mut usb), "abcdefgh");
    assert!(usb.is_empty());
    // Unplugged with DTR still up: neither open nor DTR.
    usb.set_host(false, true);
    assert!(!usb.is_open() && !usb.dtr());
}
