// Live scores: the track table against the ground truth, by the core's evaluator.

import { scoreInputs } from '../model/scoring.js';

/**
 * @typedef {import('../app.js').App} App
 */

/**
 * Scores the table against the ground truth with the core's evaluator (frames seen so far).
 * @param {App} app
 */
export function score(app) {
  if (!app.gt) return;
  const upto = app.session.lastShown(app.lastFrame);
  const inputs = scoreInputs(app.gt, app.model.table, upto);
  if (!inputs) return;
  try {
    app.scores = app.core.evaluate(inputs.gt, inputs.res, upto, { similarity: 'box' });
  } catch (e) {
    app.status(`scoring failed: ${e instanceof Error ? e.message : e}`, true);
  }
  app.panel.renderScores(app.scores, app.gtName.replace(/^file /, ''));
}
