// Opens a `rocklab report` page from disk in Debian's headless Chromium
// (through playwright-core, installed for the monitor's browser test) with
// every network request refused and recorded, then reports what the page
// shows. Run by tests/tools/report_browser_test.cpp:
//
//   node report_page.js REPORT.html OUT.json SCREENSHOT.png
//
// OUT.json: the page's mode, the uPlot data lengths, the comparison table
// cells (data-variant, data-field -> text), the bands' names and cells
// (data-band, data-field -> text), `bandPixels` (pixels of the theta
// chart's plot area in the first band's colour, rgb(90, 90, 200) within 6,
// translucent (alpha 1 .. 160 of 255: the canvas is transparent under its
// fills, so a fill reads as its own colour with its alpha); no curve, grid
// line or flag is such a colour), every table header, the CSV the
// "series as CSV" button downloads (clicked: a Blob built in the page), the
// requests made other than for the file itself, and console errors; and,
// for the page's layout at 1280 px: `pageWidth` (the document's scroll
// width), `tableRights` (each table's right edge, px), `markers` (per
// marker row of the theta chart: x of each marker drawn, number left out),
// `health` (data-node, data-field -> text), `errorChart` (the error chart's
// x and first series), `unitHeaders` (the angle headers' units), and
// `degCells`: the comparison cells after switching the angle unit to deg.
'use strict';

const fs = require('fs');
const path = require('path');
const {pathToFileURL} = require('url');
const {chromium} = require('playwright-core');

const [reportPath, outPath, screenshotPath] = process.argv.slice(2);
const STEP_TIMEOUT_MS = 20000;  // a bound on each wait, not a measurement

async function main() {
  const browser = await chromium.launch({
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const consoleErrors = [];
  const requests = [];  // anything but the report file itself and data: URLs
  try {
    const page = await browser.newPage({viewport: {width: 1280, height: 1000}, acceptDownloads: true});
    const fileUrl = pathToFileURL(path.resolve(reportPath)).href;
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    await page.route('**/*', (route) => {
      const url = route.request().url();
      if (url === fileUrl || url.startsWith('data:')) return route.continue();
      requests.push(url);
      return route.abort();
    });
    await page.goto(fileUrl, {timeout: STEP_TIMEOUT_MS});
    await page.waitForFunction(() => window.rocklabMonitor && window.rocklabMonitor.mode === 'static' &&
      window.rocklabMonitor.dataLengths().theta.length > 1, null, {timeout: STEP_TIMEOUT_MS});
    const shown = await page.evaluate(() => {
      const cells = {};
      for (const td of document.querySelectorAll('td[data-variant][data-field]')) {
        const v = td.getAttribute('data-variant');
        (cells[v] = cells[v] || {})[td.getAttribute('data-field')] = td.textContent;
      }
      const headers = Array.from(document.querySelectorAll('th')).map((th) => th.textContent);
      const bandCells = {};
      for (const td of document.querySelectorAll('td[data-band][data-field]')) {
        const b = td.getAttribute('data-band');
        (bandCells[b] = bandCells[b] || {})[td.getAttribute('data-field')] = td.textContent;
      }
      const u = window.rocklabMonitor.plots.theta;
      const box = u.bbox;
      const img = u.ctx.getImageData(Math.round(box.left), Math.round(box.top), Math.round(box.width),
        Math.round(box.height)).data;
      let bandPixels = 0;
      for (let i = 0; i < img.length; i += 4) {
        const r = img[i], g = img[i + 1], b = img[i + 2];
        const a = img[i + 3];
        if (a > 0 && a <= 160 && Math.abs(r - 90) <= 6 && Math.abs(g - 90) <= 6 && Math.abs(b - 200) <= 6) {
          bandPixels++;
        }
      }
      const health = {};
      for (const td of document.querySelectorAll('td[data-node][data-field]')) {
        const n = td.getAttribute('data-node');
        (health[n] = health[n] || {})[td.getAttribute('data-field')] = td.textContent;
      }
      const e = window.rocklabMonitor.plots.error;
      return {mode: window.rocklabMonitor.mode, dataLengths: window.rocklabMonitor.dataLengths(),
        cells, headers, title: document.title, bandNames: window.rocklabMonitor.bandNames(),
        bandCells, bandPixels, health,
        pageWidth: document.documentElement.scrollWidth,
        tableRights: Array.from(document.querySelectorAll('table'), (t) => t.getBoundingClientRect().right),
        markers: window.rocklabMonitor.markers().theta,
        errorChart: {t: e.data[0], first: e.data[1]},
        unitHeaders: Array.from(document.querySelectorAll('.angle-unit'), (x) => x.textContent)};
    });
    await page.evaluate(() => window.rocklabMonitor.setAngleUnit('deg'));
    shown.degCells = await page.evaluate(() => {
      const cells = {};
      for (const td of document.querySelectorAll('td[data-variant][data-field]')) {
        const v = td.getAttribute('data-variant');
        (cells[v] = cells[v] || {})[td.getAttribute('data-field')] = td.textContent;
      }
      return cells;
    });
    shown.degUnitHeaders = await page.evaluate(() =>
      Array.from(document.querySelectorAll('.angle-unit'), (x) => x.textContent));
    await page.evaluate(() => window.rocklabMonitor.setAngleUnit('rad'));
    const [download] = await Promise.all([
      page.waitForEvent('download', {timeout: STEP_TIMEOUT_MS}),
      page.click('#download-series'),
    ]);
    shown.csvName = download.suggestedFilename();
    shown.csv = fs.readFileSync(await download.path(), 'utf8');
    fs.mkdirSync(path.dirname(screenshotPath), {recursive: true});
    await page.screenshot({path: screenshotPath, fullPage: true});
    shown.requests = requests;
    shown.consoleErrors = consoleErrors;
    fs.writeFileSync(outPath, JSON.stringify(shown, null, 2) + '\n');
  } finally {
    await browser.close();
  }
}

main().catch((e) => {
  console.error('report_page.js: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
