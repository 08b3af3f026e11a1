import { test } from 'node:test';
import assert from 'node:assert/strict';
import { guessFormat, exportName } from '../src/io/formats.js';

test('format guessed from name and first line', () => {
  assert.equal(guessFormat('gt.txt', '1,1,10,20,30,40,1,-1,-1,-1\n'), 'mot');
  assert.equal(guessFormat('det.txt', '\n1 -1 10 20 30 40 0.9\n'), 'mot');
  assert.equal(guessFormat('0002.txt', '1 2002 2 375 1242 WSV:2d;1O10000O10000O1O100O100O1O100O1000000O1000000000O0O100O\n'), 'mots');
  assert.equal(guessFormat('x.txt', '1 1 1 10 10 100\n'), 'mot');
  assert.equal(guessFormat('a.json', '{"videos": []}'), 'coco-video');
  assert.equal(guessFormat('results', '[{"video_id": 1}]'), 'coco-video');
  assert.equal(guessFormat('annotations.xml', '<?xml version="1.0"?>'), 'cvat');
  assert.equal(guessFormat('task', '<annotations>'), 'cvat');
});

test('export names keep the stem and say the format', () => {
  assert.equal(exportName('my video.mp4', 'mot'), 'my_video.mot.txt');
  assert.equal(exportName('', 'mots'), 'tracks.mots.txt');
  assert.equal(exportName('clip.webm', 'cvat'), 'clip.cvat.xml');
  assert.equal(exportName('clip.webm', 'coco-video'), 'clip.coco-video.json');
});
