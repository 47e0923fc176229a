// Bundles the viewer into one page template: node build.mjs OUT.html.
// The template is src/page.html with the bundled style and script inlined; `kanedyn view`
// puts the model and trajectory where __KANEDYN_DATA__ stands.
import { build } from 'esbuild';
import { readFileSync, writeFileSync, mkdirSync, renameSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const out = process.argv[2];
if (!out) {
  console.error('usage: node build.mjs OUT.html');
  process.exit(2);
}
const result = await build({
  entryPoints: [join(here, 'src/main.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: 'es2020',
  charset: 'ascii', // the page's bytes are ASCII: any encoding reads them the same
  legalComments: 'eof',
  write: false,
  outdir: join(here, 'out'),
  logLevel: 'warning',
});
const pick = (ext) => result.outputFiles.filter((f) => f.path.endsWith(ext)).map((f) => f.text).join('\n');
// Inside <script> and <style>, "</" followed by the tag name would end the element early.
const script = pick('.js').replace(/<\/(script)/gi, '<\\/$1');
const style = pick('.css').replace(/<\/(style)/gi, '<\\/$1');
const page = readFileSync(join(here, 'src/page.html'), 'utf8');
const parts = page.split(/\/\*(STYLE|SCRIPT)\*\//);
if (parts.length !== 5 || !page.includes('__KANEDYN_DATA__')) {
  console.error('build.mjs: src/page.html must hold /*STYLE*/, /*SCRIPT*/ and __KANEDYN_DATA__ once each');
  process.exit(1);
}
// Functions as replacements: `$` in the bundle must not be read as a pattern.
const html = page.replace('/*STYLE*/', () => style).replace('/*SCRIPT*/', () => script);
mkdirSync(dirname(out), { recursive: true });
writeFileSync(out + '.tmp', html);
renameSync(out + '.tmp', out);
