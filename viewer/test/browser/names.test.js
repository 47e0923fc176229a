// Text from the user's files reaches the page's data (the model's name, the model file's and
// the trajectory's names): whatever it holds, the data stays data and the page gets ready,
// showing the text as text. The page's data element is <script type="application/json">;
// "<!--<script>" in it once put the HTML tokenizer in its double-escaped state, where the
// element's own </script> no longer closed it, and the page stayed blank.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { basename, dirname, join } from 'node:path';
import { EXAMPLES, kanedyn, pageData, workDir } from '../support.js';
import { openPage, checkQuiet } from './check_page.js';

const dir = workDir('browser-names');
const base = readFileSync(join(EXAMPLES, 'tennis_racket.yaml'), 'utf8');
assert.match(base, /^name: .*$/m, 'the example has a name line to replace');

// Each: the model's name (a YAML double-quoted string) and a file-name stem (with a '/', a
// folder and a name: the model file's path, shown on the page, then holds "</script>").
const cases = [
  { label: 'comment and script open', name: '<!--<script>', stem: 'a<!--<script>b' },
  { label: 'script close', name: '</script><script>window.kanedynInjected = 1</script>', stem: 'c</script>d' },
  { label: 'quotes and ampersands', name: 'it\'s "quoted" & <b>bold</b>', stem: 'q\'"&e' },
  { label: 'non-ASCII', name: 'Vélo Ω 自転車 🚲', stem: 'vélo-Ω' },
];

const contexts = [];
after(() => Promise.all(contexts.map((c) => c.close())));

for (const c of cases) {
  test(`a page for names with ${c.label} gets ready and shows them as text`, async () => {
    const yamlName = JSON.stringify(c.name); // a JSON string is a YAML double-quoted scalar
    const model = join(dir, `${c.stem}.yaml`);
    mkdirSync(dirname(model), { recursive: true });
    writeFileSync(model, base.replace(/^name: .*$/m, `name: ${yamlName}`));
    const csv = `${c.stem}.csv`;
    let r = kanedyn(dir, 'simulate', model, '--t-end', '0.2', '-o', csv);
    assert.equal(r.code, 0, r.err);
    r = kanedyn(dir, 'view', model, csv, '-o', `${c.stem}.html`);
    assert.equal(r.code, 0, r.err);
    const html = join(dir, `${c.stem}.html`);
    const data = pageData(html);
    assert.equal(data.model.name, c.name);
    assert.equal(data.model.file, model);
    assert.equal(data.source, basename(csv));
    // Inside the data element there is no '<' at all: nothing in it can end it or open another.
    const text = readFileSync(html, 'utf8');
    const m = text.match(/<script id="kanedyn-data" type="application\/json">(.*?)<\/script>/s);
    assert.ok(m && !m[1].includes('<'), 'the data element holds no "<"');
    const ctx = await openPage(html);
    contexts.push(ctx);
    const shown = await ctx.page.evaluate(() => ({
      title: document.title,
      heading: document.querySelector('.about h1').textContent,
      source: document.querySelector('.about p').textContent,
      injected: window.kanedynInjected,
    }));
    assert.equal(shown.title, `${c.name} - kanedyn view`);
    assert.equal(shown.heading, c.name);
    assert.ok(shown.source.includes(basename(csv)), shown.source);
    assert.equal(shown.injected, undefined, 'no script from the data ran');
    checkQuiet(ctx);
  });
}
