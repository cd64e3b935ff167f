// ONNX Runtime (CPU, onnxruntime-node) side of the matcher side by side.
//   node run_ort.mjs MODEL.onnx PAIRS_DIR SIZE RUNS DUMP_DIR
// Prints one JSON line like run_torch.py. Threads: intraOpNumThreads = OMP_NUM_THREADS (2),
// interOp 1, sequential execution, all graph optimisations.
import fs from "node:fs";
import path from "node:path";
import { createRequire } from "node:module";

const require = createRequire(path.join(process.env.ORT_NODE_MODULES ?? process.cwd(), "x.js"));
const ort = require("onnxruntime-node");

const [model, pairs, sizeArg, runsArg, dump] = process.argv.slice(2);
const size = Number(sizeArg), runs = Number(runsArg);
const threads = Number(process.env.OMP_NUM_THREADS ?? 2);
const session = await ort.InferenceSession.create(model, {
  intraOpNumThreads: threads, interOpNumThreads: 1, executionMode: "sequential",
  graphOptimizationLevel: "all",
});
const raw = fs.readFileSync(path.join(pairs, `pair_${size}.f32`));
const all = new Float32Array(raw.buffer, raw.byteOffset, raw.byteLength / 4);
const n = size * size;
const feeds = {
  image0: new ort.Tensor("float32", all.slice(0, n), [1, 1, size, size]),
  image1: new ort.Tensor("float32", all.slice(n, 2 * n), [1, 1, size, size]),
  classes: new ort.Tensor("int64", BigInt64Array.from([1n, 2n]), [2]),
};
let out = await session.run(feeds);  // warm-up
const times = [];
for (let r = 0; r < runs; ++r) {
  const start = process.hrtime.bigint();
  out = await session.run(feeds);
  times.push(Number(process.hrtime.bigint() - start) / 1e9);
}
const rows = (t) => Array.from({ length: t.dims[0] }, (_, i) => [t.data[2 * i], t.data[2 * i + 1]]);
fs.writeFileSync(path.join(dump, `ort_${size}.json`), JSON.stringify({
  points0: rows(out.points0), points1: rows(out.points1), mconf: Array.from(out.mconf.data),
}));
times.sort((a, b) => a - b);
console.log(JSON.stringify({
  engine: "onnxruntime", size, median_s: times[Math.floor(times.length / 2)], min_s: times[0],
  matches: out.mconf.dims[0], peak_rss_mb: process.resourceUsage().maxRSS / 1024,
}));
