//! Host criterion figures for comparison with the emulator's instruction
//! counts: the recorded scenario's ticks (parse + tick), per variant.
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use emu_common::{Bits, Reader};
use kernel::config::PAROL6_VALIDATED;
use kernel::{Fx, Kernel, Sense};
use protocol::{DialectLock, Parser};

fn inputs(data: &[u8]) -> Vec<(Sense, Option<Vec<u8>>)> {
    let mut rd = Reader::new(data).expect("scenario");
    let mut v = Vec::new();
    while let Some(t) = rd.next_tick().expect("scenario") {
        v.push((t.sense, t.frame.map(<[u8]>::to_vec)));
    }
    v
}

fn run<S: Bits>(inp: &[(Sense, Option<Vec<u8>>)]) -> u32 {
    let (mut k, authority) = Kernel::<S>::new(&PAROL6_VALIDATED);
    let parser = Parser::<S>::new(&PAROL6_VALIDATED, DialectLock::Auto);
    let mut acc = 0u32;
    for (sense, frame) in inp {
        let req = frame.as_deref().and_then(|f| parser.parse(black_box(f)).ok()).map(|c| c.into_request(&authority));
        let out = k.tick(black_box(sense), req);
        acc = acc.wrapping_add(out.act.step_rate[0] as u32);
    }
    acc
}

fn bench(c: &mut Criterion) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../data");
    let f = inputs(&std::fs::read(format!("{dir}/scenario_f32.bin")).expect("read"));
    let x = inputs(&std::fs::read(format!("{dir}/scenario_fx.bin")).expect("read"));
    let mut g = c.benchmark_group("scenario_tick_with_parse");
    g.throughput(Throughput::Elements(f.len() as u64));
    g.bench_function("f32", |b| b.iter(|| run::<f32>(black_box(&f))));
    g.bench_function("fx", |b| b.iter(|| run::<Fx>(black_box(&x))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
