//! Parser throughput on the host. Criterion prints time per frame and
//! throughput (bytes of input per second); nothing is asserted.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use kernel::config::PAROL6_VALIDATED;
use kernel::Fx;
use protocol::receiver::Receiver;
use protocol::{DialectLock, Parser, ProtocolConfig};

const DRIVER: &[u8] = b"<1532,0.123,0.050,-0.500,-0.200,1.000,0.000,0.250,0.000,-1.571,0.300,3.142,-0.000>";
const CONFIG: &[u8] = b"<42,0.1234,-0.5000,1.0000,0.2500,-1.5708,3.1416,0.0500,-0.2000,0.0000,0.0000,0.3000,-0.0000>";

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("parse_driver_frame");
    g.throughput(Throughput::Bytes(DRIVER.len() as u64));
    let pf: Parser<f32> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    g.bench_function("f32", |b| b.iter(|| pf.parse(black_box(DRIVER))));
    let px: Parser<Fx> = Parser::new(&PAROL6_VALIDATED, DialectLock::Auto);
    g.bench_function("fx", |b| b.iter(|| px.parse(black_box(DRIVER))));
    g.finish();

    let mut g = c.benchmark_group("parse_configurator_frame");
    g.throughput(Throughput::Bytes(CONFIG.len() as u64));
    g.bench_function("f32", |b| b.iter(|| pf.parse(black_box(CONFIG))));
    g.bench_function("fx", |b| b.iter(|| px.parse(black_box(CONFIG))));
    g.finish();

    // framer + parser + sequence filter, byte by byte, one frame per iteration
    let mut line = DRIVER.to_vec();
    line.push(b'\n');
    let mut g = c.benchmark_group("receiver_driver_line");
    g.throughput(Throughput::Bytes(line.len() as u64));
    let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
    g.bench_function("f32", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for &byte in black_box(&line) {
                if rx.push(byte, 0).is_some() {
                    n += 1;
                }
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
