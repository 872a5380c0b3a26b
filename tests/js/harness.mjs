// Shared by the check scripts: bounded waits, named checks and the report pytest reads.
// Each check prints "ok <name>" or "fail <name>: <reason>"; finish() exits 1 if any failed.

export const results = [];

export function within(ms, what, executor) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`timeout waiting for ${what}`)), ms);
    executor((v) => { clearTimeout(timer); resolve(v); }, (e) => { clearTimeout(timer); reject(e); });
  });
}

export async function until(ms, what, predicate) {
  const deadline = Date.now() + ms;
  while (Date.now() < deadline) {
    if (predicate()) return;
    await new Promise((r) => setTimeout(r, 50));
  }
  throw new Error(`timeout waiting for ${what}`);
}

export async function check(name, fn) {
  try {
    await fn();
    results.push(`ok ${name}`);
  } catch (err) {
    results.push(`fail ${name}: ${err && err.message ? err.message : err}`);
  }
}

export function assert(cond, text) {
  if (!cond) throw new Error(text);
}

export async function connect(lib, url, options = {}) {
  const ros = new lib.Ros({ url, ...options });
  await within(5000, 'connection', (ok, bad) => {
    ros.on('connection', () => ok());
    ros.on('error', (e) => bad(new Error(`connection error ${e}`)));
  });
  return ros;
}

export function finish(connections) {
  for (const line of results) console.log(line);
  for (const ros of connections) ros.close();
  process.exit(results.length > 0 && results.every((l) => l.startsWith('ok ')) ? 0 : 1);
}
