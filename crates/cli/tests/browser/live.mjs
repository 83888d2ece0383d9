// Plays a person's moves by clicking the live page of `chessarm play --human … --live` in
// Debian's Chromium (headless, through playwright-core; never a downloaded browser), and
// reports what the page showed, as JSON on stdout. The Rust test (crates/cli/tests/cli_live.rs)
// makes the assertions.
//
//   node live.mjs URL SCREENSHOT.png MOVE1,MOVE2,...   (UCI; a promotion's piece is answered q)
import { launch } from './chromium.mjs';

const [url, screenshot, movesArg] = process.argv.slice(2);
const moves = movesArg.split(',').filter((m) => m !== '');
const { context, close } = await launch();
const errors = [];
let quitting = false;
const requests = [];
const report = { clicked: [], plies: [], scenes: [] };
try {
  const page = await context.newPage();
  // Once the page has ended the game the server is gone by design: a poll of it refused then is
  // not an error of the page.
  page.on('console', (m) => {
    if (m.type() !== 'error') return;
    if (quitting && m.text().includes('ERR_CONNECTION_REFUSED')) return;
    errors.push(`${m.type()}: ${m.text()}`);
  });
  page.on('pageerror', (e) => errors.push(`pageerror: ${e.message}`));
  page.on('request', (r) => requests.push(r.url()));
  page.on('dialog', (d) => d.accept('q'));
  await page.goto(url);
  await page.waitForFunction(() => window.live && window.live.ready === true && window.live.state() !== null, null, { timeout: 60000 });
  for (const move of moves) {
    // The person's turn: the board takes clicks.
    await page.waitForFunction(() => window.live.state().your_turn === true, null, { timeout: 300000 });
    const before = await page.evaluate(() => window.live.state().plies);
    await page.click(`[data-square="${move.slice(0, 2)}"]`);
    await page.click(`[data-square="${move.slice(2, 4)}"]`);
    report.clicked.push(move);
    // The move and the arm's reply (or the game's end).
    await page.waitForFunction((n) => { const s = window.live.state(); return s.plies >= n + 2 || s.over; }, before, { timeout: 300000 });
    const state = await page.evaluate(() => window.live.state());
    report.plies.push(state.plies);
    if (state.over) break;
  }
  // The 3D scene of the game so far, loaded in its frame: the frame reloads after each ply, so
  // the scene of an earlier ply may still be showing (on a loaded machine); wait for this one's.
  await page.waitForFunction(() => {
    const s = window.live.scene();
    return s && s.ready && s.moves >= window.live.state().plies;
  }, null, { timeout: 60000 });
  report.scene = await page.evaluate(() => window.live.scene());
  report.final = await page.evaluate(() => window.live.state());
  report.board_text = await page.evaluate(() => document.getElementById('board').textContent);
  report.moves_text = await page.evaluate(() => document.getElementById('moves').textContent);
  report.evaluation_text = await page.evaluate(() => document.getElementById('evaluation').textContent);
  await page.screenshot({ path: screenshot });
  // Stop the game from the page.
  quitting = true;
  await page.click('#quit');
} catch (e) {
  errors.push(`probe: ${e.message}`);
} finally {
  await close();
}
console.log(JSON.stringify({ ...report, errors, requests }));
