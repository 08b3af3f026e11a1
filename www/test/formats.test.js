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

test('JSON formats are told apart by content, not extension', () => {
  const ls = JSON.stringify([
    {
      id: 1,
      data: { video: 'clip.mp4' },
      annotations: [{ result: [{ id: 'a', type: 'videorectangle', value: { sequence: [] } }] }],
    },
  ]);
  assert.equal(guessFormat('export.json', ls), 'label-studio');
  assert.equal(guessFormat('task', '{"data": {"video": "v.mp4"}, "annotations": []}'), 'label-studio');
  const scalabel = '[{"name": "a-0000001.jpg", "videoName": "a", "frameIndex": 0, "labels": []}]';
  assert.equal(guessFormat('preds.json', scalabel), 'scalabel');
  assert.equal(guessFormat('x.json', '[{"frameIndex": 3}]'), 'scalabel');
  assert.equal(guessFormat('ds.json', '{"frames": [], "config": {}}'), 'scalabel');
  // COCO-video: both have "annotations", but COCO's sit beside "videos" and "categories".
  assert.equal(guessFormat('gt.json', '{"videos": [], "annotations": [], "categories": []}'), 'coco-video');
  assert.equal(guessFormat('results.json', '[{"video_id": 1, "score": 0.9, "category_id": 1, "segmentations": []}]'), 'coco-video');
  // Malformed JSON goes to a JSON reader, which reports where.
  assert.equal(guessFormat('broken.json', '[{"data": '), 'coco-video');
});

test('YOLO txt is told from MOT by its normalised boxes', () => {
  assert.equal(guessFormat('tracks.txt', '1 0 0.5 0.5 0.25 0.5 0.9 7\n'), 'yolo');
  assert.equal(guessFormat('tracks.txt', '12 3 0.034 0.91 0.002 0.1 4\n'), 'yolo');
  // MOT detections (pixels, id -1) and ground truth stay MOT.
  assert.equal(guessFormat('det.txt', '1 -1 10 20 30 40 0.9\n'), 'mot');
  assert.equal(guessFormat('det.txt', '1 -1 10.5 20.5 30.5 40.5 0.9 -1\n'), 'mot');
  assert.equal(guessFormat('gt.txt', '1 2 100.5 200.5 30 40 1 1\n'), 'mot');
  assert.equal(guessFormat('gt.txt', '1,1,0.5,0.5,0.2,0.2,1\n'), 'mot');
});

test('export names keep the stem and say the format', () => {
  assert.equal(exportName('my video.mp4', 'mot'), 'my_video.mot.txt');
  assert.equal(exportName('', 'mots'), 'tracks.mots.txt');
  assert.equal(exportName('clip.webm', 'cvat'), 'clip.cvat.xml');
  assert.equal(exportName('clip.webm', 'coco-video'), 'clip.coco-video.json');
  assert.equal(exportName('clip.webm', 'label-studio'), 'clip.label-studio.json');
  assert.equal(exportName('clip.webm', 'scalabel'), 'clip.scalabel.json');
  assert.equal(exportName('clip.webm', 'yolo'), 'clip.yolo.txt');
});
