/* The 3D view of a report-site method page (dressmeup.viz.site_viewer): the items of
   window.DRESSMEUP_VIEWS drawn with three.js (window.THREE), one item at a time; checkboxes
   show or hide the prediction, the ground truth and the body; drag turns, wheel zooms.
   Draws only when something changed (no animation loop). */
( function () {
	'use strict';
	const root = document.getElementById( 'viewer3d' );
	const data = window.DRESSMEUP_VIEWS;
	if ( ! root || ! data ) return;
	const status = root.querySelector( '.v3d-status' );
	const THREE = window.THREE;
	if ( ! THREE || ! THREE.WebGLRenderer ) {
		status.textContent = 'The 3D view could not load three.js.';
		return;
	}
	const canvas = root.querySelector( '.v3d-canvas' );
	const probe = canvas.getContext( 'webgl2', { preserveDrawingBuffer: true } );
	if ( ! probe ) {
		status.textContent = 'This browser has no WebGL 2: the 3D view is off (the pictures above show the same items).';
		return;
	}

	function bytes( b64 ) {
		const s = atob( b64 );
		const out = new Uint8Array( s.length );
		for ( let i = 0; i < s.length; i ++ ) out[ i ] = s.charCodeAt( i );
		return out.buffer;
	}

	const lut = new Uint8Array( bytes( data.lut ) );
	const vmax = Math.max( data.vmax, 1e-9 );

	// the colour bar: the same 256 colours as the vertices, 0 .. vmax mm
	const bar = root.querySelector( '.v3d-cbar' );
	const bctx = bar.getContext( '2d' );
	for ( let i = 0; i < bar.width; i ++ ) {
		const k = Math.min( 255, Math.floor( i * 256 / bar.width ) ) * 3;
		bctx.fillStyle = `rgb(${lut[ k ]},${lut[ k + 1 ]},${lut[ k + 2 ]})`;
		bctx.fillRect( i, 0, 1, bar.height );
	}

	function geometry( m, item, err ) {
		const q = new Uint16Array( bytes( m.pos ) );
		const pos = new Float32Array( q.length );
		for ( let i = 0; i < q.length; i ++ ) pos[ i ] = item.lo[ i % 3 ] + q[ i ] * item.step[ i % 3 ];
		const g = new THREE.BufferGeometry();
		g.setAttribute( 'position', new THREE.BufferAttribute( pos, 3 ) );
		const idx = m.idx32 ? new Uint32Array( bytes( m.idx ) ) : new Uint16Array( bytes( m.idx ) );
		g.setIndex( new THREE.BufferAttribute( idx, 1 ) );
		g.computeVertexNormals();
		if ( err ) {
			const e = new Float32Array( bytes( m.err ) );
			const col = new Float32Array( e.length * 3 );
			for ( let i = 0; i < e.length; i ++ ) {
				const k = Math.min( 255, Math.max( 0, Math.round( 255 * e[ i ] / vmax ) ) ) * 3;
				// the colour map is sRGB; the renderer works in linear light
				const c = new THREE.Color().setRGB( lut[ k ] / 255, lut[ k + 1 ] / 255, lut[ k + 2 ] / 255, THREE.SRGBColorSpace );
				col[ 3 * i ] = c.r; col[ 3 * i + 1 ] = c.g; col[ 3 * i + 2 ] = c.b;
			}
			g.setAttribute( 'color', new THREE.BufferAttribute( col, 3 ) );
		}
		return g;
	}

	const renderer = new THREE.WebGLRenderer( { canvas: canvas, context: probe, antialias: true } );
	renderer.setPixelRatio( window.devicePixelRatio || 1 );
	renderer.setSize( canvas.width, canvas.height, false );
	renderer.setClearColor( 0xf6f7f9 );
	const scene = new THREE.Scene();
	const camera = new THREE.PerspectiveCamera( 35, canvas.width / canvas.height, 0.01, 100 );
	scene.add( new THREE.HemisphereLight( 0xffffff, 0x8a8f99, 1.6 ) );
	const head = new THREE.DirectionalLight( 0xffffff, 1.4 );
	head.position.set( 0.3, 0.4, 1 );
	camera.add( head );  // a head light: every side the camera turns to is lit
	scene.add( camera );
	const controls = new THREE.OrbitControls( camera, canvas );
	controls.enableDamping = false;

	const materials = {
		pred: new THREE.MeshLambertMaterial( { vertexColors: true, side: THREE.DoubleSide } ),
		gt: new THREE.MeshLambertMaterial( { color: 0x9aa6bd, side: THREE.DoubleSide, transparent: true, opacity: 0.45, depthWrite: false } ),
		body: new THREE.MeshLambertMaterial( { color: 0xd9b8a0, side: THREE.FrontSide } ),
	};
	const boxes = Array.from( root.querySelectorAll( 'input[data-layer]' ) );
	let meshes = {};

	function draw() {
		for ( const b of boxes ) if ( meshes[ b.dataset.layer ] ) meshes[ b.dataset.layer ].visible = b.checked;
		renderer.render( scene, camera );
		root.dataset.frames = String( Number( root.dataset.frames || 0 ) + 1 );
	}

	function show( i ) {
		for ( const m of Object.values( meshes ) ) {
			scene.remove( m );
			m.geometry.dispose();
		}
		meshes = {};
		const item = data.items[ i ];
		for ( const layer of [ 'body', 'pred', 'gt' ] ) {
			if ( ! item[ layer ] ) continue;
			const mesh = new THREE.Mesh( geometry( item[ layer ], item, layer === 'pred' ), materials[ layer ] );
			mesh.renderOrder = layer === 'gt' ? 1 : 0;  // the see-through truth last
			meshes[ layer ] = mesh;
			scene.add( mesh );
		}
		// frame the item: the prediction and truth fill the view, up along the tallest side
		const box = new THREE.Box3().setFromObject( meshes.pred ).union( new THREE.Box3().setFromObject( meshes.gt ) );
		const size = box.getSize( new THREE.Vector3() );
		const center = box.getCenter( new THREE.Vector3() );
		const axes = [ size.x, size.y, size.z ];
		const up = axes.indexOf( Math.max( ...axes ) );
		camera.up.set( up === 0 ? 1 : 0, up === 1 ? 1 : 0, up === 2 ? 1 : 0 );
		const horiz = [ 0, 1, 2 ].filter( ( k ) => k !== up );
		const thin = axes[ horiz[ 0 ] ] <= axes[ horiz[ 1 ] ] ? horiz[ 0 ] : horiz[ 1 ];  // look along it
		const dir = new THREE.Vector3( thin === 0 ? 1 : 0, thin === 1 ? 1 : 0, thin === 2 ? 1 : 0 );
		const radius = box.getBoundingSphere( new THREE.Sphere() ).radius;
		const dist = radius / Math.sin( THREE.MathUtils.degToRad( camera.fov / 2 ) ) * 1.05;
		camera.position.copy( center ).addScaledVector( dir, dist );
		camera.near = dist / 100;
		camera.far = dist * 100;
		camera.updateProjectionMatrix();
		controls.target.copy( center );
		controls.update();
		draw();
	}

	controls.addEventListener( 'change', draw );
	for ( const b of boxes ) b.addEventListener( 'change', draw );
	const select = root.querySelector( '.v3d-item' );
	select.addEventListener( 'change', () => show( Number( select.value ) ) );
	show( 0 );
	root.dataset.ready = '1';
}() );
