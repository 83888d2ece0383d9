// Opens a chessarm replay.html from file:// in Debian's Chromium (headless, through
// playwright-core; never a downloaded browser) and reports what the page shows, as JSON on
// stdout. The Rust tests (crates/cli/tests/cli_replay.rs) make the assertions.
//
//   node probe.mjs REPLAY.html SCREENSHOT.png [--run N] [--times t1,t2,...] [--shot-at T]
import path from 'node:path';
import { launch } from './chromium.mjs';
import { pathToFileURL } from 'node:url';

const [html, screenshot, ...rest] = process.argv.slice(2);
const option = (name, fallback) => {
  const i = rest.indexOf(name);
  return i >= 0 ? rest[i + 1] : fallback;
};
const run = Number(option('--run', '0'));
const times = option('--times', '').split(',').filter((s) => s !== '').map(Number);
const shotAt = option('--shot-at', null);
const { context, close } = await launch();
const errors = [];
const requests = [];
try {
  const page = await context.newPage();
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') errors.push(`${m.type()}: ${m.text()}`); });
  page.on('pageerror', (e) => errors.push(`pageerror: ${e.message}`));
  page.on('request', (r) => { const u = r.url(); if (!u.startsWith('file:') && !u.startsWith('blob:') && !u.startsWith('data:')) requests.push(u); });
  await page.goto(pathToFileURL(path.resolve(html)).href);
  await page.waitForFunction(() => window.chessarm && window.chessarm.ready === true, null, { timeout: 60000 });
  const report = await page.evaluate(({ run, times }) => {
    const api = window.chessarm;
    api.selectRun(run);
    const samples = times.map((t) => { api.seek(t); return { t, tool: api.toolPosition(), phase: api.phase(), ply: api.currentMove() }; });
    // Each moved piece just before its grip and just after its release, forwards through the
    // game and then backwards: where it stood and where it was put down.
    const handled = api.handled();
    const at = (h, t) => { api.seek(t); return api.pieces()[h.piece].position; };
    const visit = (list) => list.map((h) => ({ piece: h.piece, before: at(h, h.grip_t - 1e-3), after: at(h, h.release_t + 1e-3) }));
    const forwards = visit(handled);
    const backwards = visit([...handled].reverse()).reverse();
    // Stepping through the moves with shift+arrows, down and up: the ply each step lands on.
    api.seek(0);
    const down = [api.stepMove(0)];
    for (let i = 0; i < api.moves().length + 1; i++) down.push(api.stepMove(1));
    const up = [];
    for (let i = 0; i < api.moves().length + 1; i++) up.push(api.stepMove(-1));
    // Each move's closest pair at its instant, and 1 s later (the marker gone).
    const closest = api.moves().map((m) => {
      const c = api.closestOf(m.ply);
      if (!c) return null;
      api.seek(c.t);
      const at = api.closest();
      api.seek(c.t + 1);
      return { ply: m.ply, closest: c, at, after: api.closest() };
    });
    api.seek(api.duration());
    return { closest, runs: api.runs(), webgl: api.webgl, three: api.three, duration: api.duration(), samples,
      pieces: api.pieces(), moves: api.moves(), handled, forwards, backwards, down, up };
  }, { run, times });
  // The screenshot: the player's view at the given instant, rendered, with the points to look at.
  const view = await page.evaluate((t) => {
    const api = window.chessarm;
    api.camera('player');
    api.seek(t === null ? api.duration() / 2 : Number(t));
    api.render();
    return api.landmarks();
  }, shotAt);
  await page.screenshot({ path: screenshot });
  report.landmarks = view;
  report.errors = errors;
  report.requests = requests;
  process.stdout.write(JSON.stringify(report));
} finally {
  await close();
}
