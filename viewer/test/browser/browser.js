// Starting Debian's chromium headless through puppeteer-core (no browser download), with a
// fresh profile and no background networking (the machine's network is closed).
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import puppeteer from 'puppeteer-core';

export const CHROMIUM = process.env.KANEDYN_CHROMIUM || '/usr/bin/chromium';

export async function launch() {
  if (!existsSync(CHROMIUM)) {
    throw new Error(`no chromium at ${CHROMIUM}: scripts/install-deps.sh installs Debian's (or set KANEDYN_CHROMIUM)`);
  }
  const profile = mkdtempSync(join(tmpdir(), 'kanedyn-chromium-'));
  const browser = await puppeteer.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync',
      `--user-data-dir=${profile}`,
      // WebGL without a GPU: ANGLE on SwiftShader, the software renderer chromium ships.
      '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    ],
  });
  const close = async () => {
    await browser.close();
    rmSync(profile, { recursive: true, force: true });
  };
  return { browser, close };
}
