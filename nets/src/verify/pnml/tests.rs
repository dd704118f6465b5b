use super::*;

fn wrap(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<pnml xmlns=\"{PNML_NAMESPACE}\">\n<net id=\"n\" type=\"{PTNET_TYPE}\">\n{body}\n</net>\n</pnml>\n"
    )
}

fn error_of(text: &str) -> String {
    match read_ptnet(text) {
        Ok(net) => panic!("expected an error, read {net:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn nested_pages_references_and_weights_are_flattened() {
    let text = wrap(
        r#"<name><text>Two pages</text></name>
<page id="top">
  <place id="a"><name><text>A place</text></name><initialMarking><text> 3 </text></initialMarking></place>
  <transition id="t"><name><text>go</text></name><graphics><position x="1" y="2"/></graphics></transition>
  <page id="inner">
    <place id="b"/>
    <referencePlace id="ra" ref="a"/>
    <referencePlace id="rra" ref="ra"/>
    <referenceTransition id="rt" ref="t"/>
    <arc id="x1" source="rra" target="rt"><inscription><text>2</text></inscription></arc>
    <arc id="x2" source="rt" target="b"/>
    <arc id="x3" source="a" target="t"/>
  </page>
</page>"#,
    );
    let net = read_ptnet(&text).unwrap();
    assert_eq!(net.name, "Two pages");
    assert_eq!(net.places.len(), 2);
    assert_eq!(net.places[0].name, "A place");
    assert_eq!(net.places[0].initial, 3);
    assert_eq!(net.places[1].name, "b");
    assert_eq!(net.places[1].initial, 0);
    assert_eq!(net.transitions.len(), 1);
    assert_eq!(net.transitions[0].name, "go");
    // Two arcs a -> t (weights 2 and 1, one through a chain of references) merge.
    assert_eq!(net.transitions[0].pre, vec![(0, 3)]);
    assert_eq!(net.transitions[0].post, vec![(1, 1)]);
}

#[test]
fn toolspecific_payloads_are_kept_verbatim() {
    let text = wrap(
        r#"<page id="p"><transition id="t"><toolspecific tool="petrel" version="1"><event name="takeoff"/><action>arm</action></toolspecific></transition></page>"#,
    );
    let doc = read_document(&text).unwrap();
    let ts = &doc.nets[0].pages[0].transitions[0].toolspecific;
    assert_eq!(ts.len(), 1);
    assert_eq!(ts[0].tool, "petrel");
    assert_eq!(
        ts[0].content,
        r#"<event name="takeoff"/><action>arm</action>"#
    );
    // and written back unchanged
    let again = read_document(&write_document(&doc)).unwrap();
    assert_eq!(again.nets[0].pages[0].transitions[0].toolspecific, *ts);
}

#[test]
fn write_then_read_gives_the_same_net() {
    let mut net = PtNet::new("round & trip");
    net.name = "a <net> \"named\"".into();
    let a = net.add_place("a", 1);
    let b = net.add_place("b-t", 0);
    let c = net.add_place("c", 7);
    net.add_transition("t", &[(a, 1), (c, 3)], &[(b, 2)]);
    net.add_transition("b", &[(b, 1)], &[(a, 1), (c, 1)]);
    // `b-t` + `t` collides with the arc id scheme; the writer must keep ids unique.
    net.add_transition("b-t-t", &[], &[(b, 1)]);
    net.places[2].name = "see".into();
    let text = write_ptnet(&net);
    assert_eq!(read_ptnet(&text).unwrap(), net);
}

#[test]
fn malformed_xml_is_reported_with_its_position() {
    let text =
        "<?xml version=\"1.0\"?>\n<pnml>\n  <net id=\"n\" type=\"ptnet\">\n  </nett>\n</pnml>\n";
    assert_eq!(
        error_of(text),
        "4:3: malformed XML: expected 'net' tag, not 'nett'"
    );
}

#[test]
fn a_dangling_arc_is_reported_with_its_position() {
    let text = wrap("<page id=\"p\">\n<place id=\"a\"/>\n<arc id=\"x\" source=\"a\" target=\"nowhere\"/>\n</page>");
    assert_eq!(
        error_of(&text),
        "6:1: arc `x`: target `nowhere` is not a node of the net"
    );
}

#[test]
fn an_unknown_reference_is_reported_with_its_position() {
    let text = wrap(
        "<page id=\"p\">\n<place id=\"a\"/>\n  <referencePlace id=\"r\" ref=\"ghost\"/>\n</page>",
    );
    assert_eq!(
        error_of(&text),
        "6:3: reference `r` points to `ghost`, which is not a place of the net"
    );
    let text = wrap(
        "<page id=\"p\">\n<transition id=\"t\"/>\n<referencePlace id=\"r\" ref=\"t\"/>\n</page>",
    );
    assert_eq!(
        error_of(&text),
        "6:1: reference `r` points to `t`, which is not a place of the net"
    );
}

#[test]
fn a_cycle_of_references_is_reported() {
    let text = wrap("<page id=\"p\">\n<referencePlace id=\"r1\" ref=\"r2\"/>\n<referencePlace id=\"r2\" ref=\"r1\"/>\n</page>");
    assert_eq!(
        error_of(&text),
        "5:1: reference `r1` is part of a cycle of references"
    );
}

#[test]
fn other_bad_inputs_are_reported() {
    assert_eq!(
        error_of(&wrap("<page id=\"p\">\n<place id=\"a\"><initialMarking><text>-1</text></initialMarking></place>\n</page>")),
        "5:31: initial marking `-1` is not a natural number"
    );
    assert_eq!(
        error_of(&wrap(
            "<page id=\"p\">\n<place id=\"a\"/>\n<transition id=\"a\"/>\n</page>"
        )),
        "6:1: id `a` is used twice"
    );
    assert_eq!(
        error_of(&wrap("<page id=\"p\">\n<place id=\"a\"/><place id=\"b\"/>\n<arc id=\"x\" source=\"a\" target=\"b\"/>\n</page>")),
        "6:1: arc `x` must join a place and a transition"
    );
    assert_eq!(
        error_of(&wrap(
            "<page id=\"p\">\n<arc source=\"a\" target=\"b\"/>\n</page>"
        )),
        "5:1: <arc> has no `id` attribute"
    );
    assert_eq!(
        error_of("<net/>"),
        "1:1: the root element is <net>, expected <pnml>"
    );
    assert_eq!(error_of("<pnml/>"), "1:1: the document holds no <net>");
    assert!(
        error_of("<pnml><net id=\"n\" type=\"symmetricnet\"/></pnml>")
            .starts_with("1:7: the net type is `symmetricnet`")
    );
    assert_eq!(
        error_of(""),
        "1:1: malformed XML: the document does not have a root node"
    );
}
