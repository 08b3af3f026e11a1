//! Unit tests of `io::coco_video` (a file of their own: the module's code is long enough).

use super::*;

fn square_rle(w: u32, h: u32, x0: usize, y0: usize, s: usize) -> Rle {
    let mut m = vec![0u8; (w * h) as usize];
    for y in y0..y0 + s {
        for x in x0..x0 + s {
            m[y * w as usize + x] = 1;
        }
    }
    Rle::encode(w, h, &m).unwrap()
}

#[test]
fn axis_aligned_polygon_covers_pixel_centres() {
    // A square with corners on pixel boundaries covers exactly the pixels inside it.
    let r = rle_from_polygon(&[2.0, 1.0, 6.0, 1.0, 6.0, 4.0, 2.0, 4.0], 8, 10).unwrap();
    let m = r.to_mask();
    assert_eq!(m.bbox(), BBox::new(2.0, 1.0, 4.0, 3.0));
    assert_eq!(r.area(), 12);
}

#[test]
fn polygon_rejects_bad_input() {
    assert!(rle_from_polygon(&[0.0, 0.0, 1.0, 1.0], 5, 5).is_err());
    assert!(rle_from_polygon(&[0.0, 0.0, 1.0, f64::NAN, 2.0, 0.0], 5, 5).is_err());
    assert!(matches!(
        rle_from_polygon(&[0.0, 0.0, 1e9, 0.0, 0.0, 1e9], 5, 5),
        Err(PolygonError::TooLarge { .. })
    ));
}

#[test]
fn errors_point_at_the_annotation() {
    let text = "{\"videos\":[{\"id\":1,\"width\":4,\"height\":3,\"length\":2}],\n\"annotations\":[\n{\"id\":5,\"video_id\":9,\"category_id\":1,\"segmentations\":[null,null]}]}";
    match parse_coco_video(text, "x.json") {
        Err(IoError::Json {
            line,
            column,
            message,
            ..
        }) => {
            assert_eq!((line, column), (3, 1), "{message}");
            assert!(message.contains("unknown video 9"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn roundtrip_masks_boxes_and_flags() {
    let video = VideoInfo {
        id: 3,
        width: 6,
        height: 5,
        length: 4,
        file_names: vec![],
    };
    let mut a = Record::from_box(1, 7, BBox::new(1.0, 1.0, 2.0, 2.0));
    a.class = 2;
    a.mask = Some(square_rle(6, 5, 1, 1, 2));
    let mut b = a.clone();
    b.frame = 3;
    b.flags.interpolated = true;
    b.flags.occluded = true;
    let mut c = Record::from_box(2, 8, BBox::new(0.5, 0.25, 3.0, 1.5));
    c.class = 1;
    let recs = vec![a, c, b];
    let cats = vec![
        Category {
            id: 1,
            name: "a".into(),
        },
        Category {
            id: 2,
            name: "b".into(),
        },
    ];
    let text = write_coco_video(&[(video.clone(), &recs)], &cats).unwrap();
    let back = parse_coco_video(&text, "rt.json").unwrap();
    assert_eq!(back.categories, cats);
    assert_eq!(back.videos.len(), 1);
    assert_eq!(back.videos[0].video, video);
    let mut want = recs.clone();
    want.sort_by_key(|r| (r.frame, r.id));
    assert_eq!(back.videos[0].records, want);
}
