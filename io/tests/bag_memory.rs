//! A damaged bag's length fields must not decide an allocation: a file of a few hundred
//! bytes declaring a 200 MiB record is refused at the cost of its own bytes. Measured with a
//! counting allocator (this test binary's only test, so nothing else allocates meanwhile).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use kincal_io::rosbag::{BagOptions, MeasurementTopic, import_bag_bytes};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let live = LIVE.fetch_add(layout.size(), Ordering::SeqCst) + layout.size();
        PEAK.fetch_max(live, Ordering::SeqCst);
        // SAFETY: the caller's layout, passed on.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
        // SAFETY: allocated by `alloc` above with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

const MAGIC: &[u8] = b"\x89MCAP0\r\n";
const DECLARED: u64 = 200 << 20;

fn record(opcode: u8, declared: u64, body: &[u8]) -> Vec<u8> {
    let mut out = vec![opcode];
    out.extend_from_slice(&declared.to_le_bytes());
    out.extend_from_slice(body);
    out
}

fn mcap_str(s: &str) -> Vec<u8> {
    let mut out = (s.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(s.as_bytes());
    out
}

/// A header record, then `tail`.
fn bag(tail: &[u8]) -> Vec<u8> {
    let mut header = mcap_str("ros2");
    header.extend_from_slice(&mcap_str("kincal-test"));
    let mut bag = MAGIC.to_vec();
    bag.extend(record(0x01, header.len() as u64, &header));
    bag.extend_from_slice(tail);
    bag
}

#[test]
fn a_declared_200_mib_record_costs_the_file_not_the_declaration() {
    // A top-level message record declaring 200 MiB with 16 bytes of it present.
    let message = bag(&record(0x05, DECLARED, &[0; 16]));
    // An uncompressed chunk declaring 200 MiB of records, the first one 100 MiB.
    let mut chunk_header = Vec::new();
    chunk_header.extend_from_slice(&[0; 16]); // start and end times
    chunk_header.extend_from_slice(&(DECLARED - 40).to_le_bytes()); // uncompressed size
    chunk_header.extend_from_slice(&0u32.to_le_bytes()); // CRC: not checked
    chunk_header.extend_from_slice(&mcap_str("")); // uncompressed
    chunk_header.extend_from_slice(&(DECLARED - 40).to_le_bytes()); // records' bytes
    chunk_header.extend(record(0x05, 100 << 20, &[0; 16]));
    let chunk = bag(&record(0x06, DECLARED, &chunk_header));
    let opts = BagOptions::new("/joint_states", MeasurementTopic::Pose("/tool".into()));
    for (what, bytes) in [("message", &message), ("chunk", &chunk)] {
        let before = LIVE.load(Ordering::SeqCst);
        PEAK.store(before, Ordering::SeqCst);
        let Err(err) = import_bag_bytes(&[("damaged.mcap", bytes)], &opts) else {
            panic!("the truncated {what} is refused");
        };
        let extra = PEAK.load(Ordering::SeqCst) - before;
        assert!(
            err.to_string()
                .contains("damaged.mcap: not a readable MCAP file"),
            "{err}"
        );
        assert!(
            extra < 4 << 20,
            "a {}-byte {what} file declaring {DECLARED} bytes allocated {extra} bytes",
            bytes.len()
        );
    }
}
